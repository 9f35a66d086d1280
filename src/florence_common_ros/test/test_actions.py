"""SentGoal calls a goal's active and done callbacks once each, also when rospy's
SimpleActionClient drops the transitions (its goal handle assigned after the server answered)."""

import time

import pytest

pytestmark = pytest.mark.ros


def _until(condition, timeout, poll=None):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if poll is not None:
            poll()
        if condition():
            return True
        time.sleep(0.02)
    return False


@pytest.fixture(scope="module")
def nav(rospy_node):
    import actionlib
    from move_base_msgs.msg import MoveBaseAction

    from florence_common_ros.mock_move_base import MockMoveBase, Reply

    behaviour = {"reply": Reply("succeeded", 0.3)}
    behaviour["mock"] = MockMoveBase(name="sent_goal_nav", policy=lambda *_goal: behaviour["reply"])
    client = actionlib.SimpleActionClient("sent_goal_nav", MoveBaseAction)
    assert client.wait_for_server(rospy_node.Duration(10))
    return client, behaviour


def _send(client, x=1.0, drop=False):
    from move_base_msgs.msg import MoveBaseGoal

    from florence_common_ros.actions import SentGoal
    from florence_common_ros.convert import pose_stamped

    calls = []
    if drop:  # what actionlib does when the status beats send_goal's assignment of its handle
        client._handle_transition = lambda _gh: None
    try:
        sent = SentGoal(client, MoveBaseGoal(target_pose=pose_stamped(x, 0.0, 0.0, "map")),
                        active_cb=lambda: calls.append("active"), done_cb=calls.append)
    finally:
        if drop:
            del client._handle_transition  # the class's method again, for later goals
    return sent, calls


def test_callbacks_come_once_each_with_or_without_polling(nav):
    from actionlib_msgs.msg import GoalStatus

    client, _behaviour = nav
    sent, calls = _send(client)
    assert _until(lambda: sent.done, 10, poll=sent.poll)
    assert _until(lambda: len(calls) == 2, 5)
    for _ in range(5):
        assert sent.poll()
    time.sleep(0.2)
    assert calls == ["active", GoalStatus.SUCCEEDED] and sent.state == GoalStatus.SUCCEEDED


def test_dropped_transitions_are_delivered_by_poll(nav):
    from actionlib_msgs.msg import GoalStatus

    from florence_common_ros.mock_move_base import Reply

    client, behaviour = nav
    behaviour["reply"] = Reply("hang")
    try:
        sent, calls = _send(client, drop=True)
        time.sleep(0.5)
        assert calls == [] and client.get_state() == GoalStatus.ACTIVE  # actionlib told nobody
        assert _until(lambda: calls == ["active"], 5, poll=sent.poll)
        client.cancel_goal()
        assert _until(lambda: sent.done, 10, poll=sent.poll), calls
        assert calls == ["active", GoalStatus.PREEMPTED]

        behaviour["reply"] = Reply("aborted", 0.0, "at once")
        sent, calls = _send(client, x=2.0, drop=True)
        assert _until(lambda: sent.done, 10, poll=sent.poll), calls
        assert calls[-1] == GoalStatus.ABORTED and calls.count(GoalStatus.ABORTED) == 1
        assert client.get_goal_status_text() == "at once"
    finally:
        behaviour["reply"] = Reply("succeeded", 0.3)


def test_a_replaced_goal_is_no_longer_polled(nav):
    from florence_common_ros.mock_move_base import Reply

    client, behaviour = nav
    behaviour["reply"] = Reply("hang")
    try:
        old, old_calls = _send(client, drop=True)
        new, new_calls = _send(client, x=3.0)
        assert _until(lambda: new_calls == ["active"], 10, poll=new.poll)
        for _ in range(10):
            assert not old.poll()  # the client's state is the new goal's: not the old one's to deliver
        assert old_calls == []
        client.cancel_all_goals()
        assert _until(lambda: new.done, 10, poll=new.poll)
    finally:
        behaviour["reply"] = Reply("succeeded", 0.3)


@pytest.mark.parametrize("locked", [False, True])
def test_a_goal_answered_before_send_goal_returns_ends_with_our_client_only(nav, locked):
    """ros/actionlib#206: send_goal publishes the goal, then assigns its handle. Here the window is
    held open until the server's result has come in (on a loaded machine the client's thread may
    wait that long for a core): actionlib's client drops the result and wait_for_result runs out;
    ours takes it."""
    import actionlib
    import rospy
    from actionlib_msgs.msg import GoalStatus
    from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal

    from florence_common_ros.actions import SimpleActionClient
    from florence_common_ros.convert import pose_stamped
    from florence_common_ros.mock_move_base import Reply

    _client, behaviour = nav
    client = (SimpleActionClient if locked else actionlib.SimpleActionClient)("sent_goal_nav", MoveBaseAction)
    assert client.wait_for_server(rospy.Duration(10))
    manager = client.action_client.manager
    publish = manager.send_goal_fn

    answered = behaviour["mock"].outcomes

    def publish_then_stall(action_goal):  # until the server has sent its answer
        before = len(answered)
        publish(action_goal)
        assert _until(lambda: len(answered) > before, 10), "no answer from the server"
        if locked:  # our client's subscribers wait for send_goal: give the answer time to reach them
            time.sleep(0.3)
        else:  # actionlib's took it, in the handle send_goal has not returned yet
            assert _until(lambda: any(c.action_goal.goal_id.id == action_goal.goal_id.id and c.latest_result
                                      for c in manager._get_live_statuses()), 10), "the result did not come"

    behaviour["reply"] = Reply("aborted", 0.0, "at once")
    manager.send_goal_fn = publish_then_stall
    try:
        client.send_goal(MoveBaseGoal(target_pose=pose_stamped(1.0, 0.0, 0.0, "map")))
        manager.send_goal_fn = publish
        ended = client.wait_for_result(rospy.Duration(3.0))
        assert client.get_goal_status_text() == "at once"  # the client's goal handle heard it either way
        if locked:
            assert ended and client.get_state() == GoalStatus.ABORTED
        else:
            assert not ended, "actionlib's client took the result: the race this client exists for is gone"
    finally:
        manager.send_goal_fn = publish
        behaviour["reply"] = Reply("succeeded", 0.3)
