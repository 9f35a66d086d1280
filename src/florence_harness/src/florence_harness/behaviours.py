"""Test helpers for the behaviours' action servers (follow_me, approach_me, ...)."""

import time


def finish(client, timeout=10.0):
    """Wait (``timeout`` s of ROS time) for a SimpleActionClient's goal to end: (state, text, result)."""
    import rospy

    assert client.wait_for_result(rospy.Duration(timeout)), "no result"
    return client.get_state(), client.get_goal_status_text(), client.get_result()


def assert_refused_at_once(client, cases, within=2.0):
    """Each (goal, reason) of ``cases`` ends ABORTED with ``reason`` in its text within ``within`` s."""
    from actionlib_msgs.msg import GoalStatus

    for goal, reason in cases:
        start = time.monotonic()
        client.send_goal(goal)
        state, text, _ = finish(client)
        assert state == GoalStatus.ABORTED and reason in text, (reason, state, text)
        assert time.monotonic() - start < within, f"{reason}: not at once ({time.monotonic() - start:.1f} s)"
