"""user_tracker_ni and filter_user_tracker in florence_sim, judged against the simulator's people:
people walking in front of the robot tracked where they are; a person who walks out of view and
comes back gets the same persistent id; Stop forgets every track and Start begins afresh; the
filter drops the entries no sensor saw lately. The tracker reads only the Kinect, the laser and tf;
the judgement (florence_eval.people_metrics) compares in the robot's base frame, the tracks through
odometry, the people through the true pose.

(Here, not in user_tracker_ni's tests: florence_eval depends on user_tracker_ni.)"""

import math

import pytest

from florence_common.processes import wait_for

pytestmark = [pytest.mark.scenario, pytest.mark.slow]

RED, BLUE = [0.85, 0.1, 0.1], [0.1, 0.3, 0.85]
START = (0.6, 2.5, 0.0)


@pytest.fixture(scope="module")
def stack(ros_master, rospy_node, tf_buffer):
    """florence_sim (nobody at first), map_server, amcl and user_tracker.launch, as bench/people.py."""
    import rosgraph
    from florence_eval.people_session import PeopleSession, launch_stack

    master = rosgraph.Master("/pytest")
    had_sim_time = master.hasParam("/use_sim_time")
    tf_buffer.clear()
    procs = launch_stack(ros_master, START, real_time_factor=1.5, seed=2)
    session = PeopleSession(filtered_topic="/filtered_tracked_users")
    try:
        wait_for(lambda: session.sim_now() > 1.0, 120, what=f"florence_sim's clock\n{procs[0].output()}")
        rospy_node.wait_for_service("/user_tracker_ni_node/Start", 60)
        yield session, procs
    finally:
        session.close()
        for proc in reversed(procs):
            proc.stop()
        if not had_sim_time and master.hasParam("/use_sim_time"):
            master.deleteParam("/use_sim_time")
        tf_buffer.clear()


def scene(session, rospy_node, robot=START, **people):
    """Nobody but ``people`` (id -> people-file spec), the robot at ``robot``, the tracker restarted;
    returns the simulated time the tracker started."""
    from user_tracker_ni.srv import Start, Stop

    rospy_node.ServiceProxy("/user_tracker_ni_node/Stop", Stop)()
    session.remove_people()
    session.set_robot(*robot)  # and amcl is told so
    for pid, spec in people.items():
        session.set_person(pid, **spec)
    session.wait_sim(1.0)
    assert rospy_node.ServiceProxy("/user_tracker_ni_node/Start", Start)().success
    return session.sim_now()


def test_two_people_crossing_are_tracked_where_they_are(stack, rospy_node):
    """The bench's two_crossing scenario: two people cross in front of the robot, one hiding the
    other for a moment; both tracked where they are, neither changes id."""
    from florence_eval.people_metrics import evaluate
    from florence_eval.people_scenarios import by_name

    session, procs = stack
    (crossing,) = by_name(["two_crossing"])
    t0 = scene(session, rospy_node, robot=crossing.robot, **crossing.people)
    session.wait_sim(20.0)
    result = evaluate(session.frames(t0 + 1.0, session.sim_now()))
    detail = f"{result}\n{procs[-1].output(4000)}"
    assert result["objects"] > 100, detail
    assert result["mota"] >= 0.8, detail
    assert result["motp_m"] <= 0.15, detail
    assert result["id_switches"] == 0, detail


def test_a_person_who_leaves_the_view_and_returns_keeps_the_id(stack, rospy_node):
    """Alice walks out of the Kinect's view to the robot's left, through the door into the
    corridor, where the wall hides her from the laser too (her track times out), and comes back:
    her persistent id is the one she had."""
    from florence_eval.people_metrics import evaluate

    session, procs = stack
    from florence_eval.people_scenarios import LEAVE_AND_RETURN

    t0 = scene(session, rospy_node, alice={"path": LEAVE_AND_RETURN, "speed": 0.6, "mode": "back_and_forth",
                                           "pause": 1.5, "shirt": RED})
    session.wait_sim(40.0)
    result = evaluate(session.frames(t0 + 1.0, session.sim_now()))
    detail = f"{result}\n{procs[-1].output(4000)}"
    assert result["returns"] >= 1, detail
    assert result["returns_with_old_id"] == result["returns"], detail
    assert result["id_switches"] == 0, detail


def test_stop_clears_every_track_and_start_begins_afresh(stack, rospy_node):
    from user_tracker_ni.msg import TrackedUsers
    from user_tracker_ni.srv import Start, Stop

    session, _ = stack
    scene(session, rospy_node, bob={"pose": [2.6, 2.6, math.pi], "shirt": BLUE})

    def tracked():
        msg = rospy_node.wait_for_message("/tracked_users", TrackedUsers, 10)
        return msg if msg.user_ids else None

    first = wait_for(tracked, 30, what="bob tracked")
    assert rospy_node.ServiceProxy("/user_tracker_ni_node/Stop", Stop)().success
    empty = rospy_node.wait_for_message("/tracked_users", TrackedUsers, 10)
    assert list(empty.user_ids) == [] and empty.num_users_tracked == 0
    again = rospy_node.ServiceProxy("/user_tracker_ni_node/Stop", Stop)()
    assert again.success and "already" in again.message
    assert rospy_node.ServiceProxy("/user_tracker_ni_node/Start", Start)().success
    second = wait_for(tracked, 30, what="bob tracked again")
    assert list(second.user_ids) == list(first.user_ids), "the same person, the same persistent id"
    assert list(second.user_ids_ni) != list(first.user_ids_ni), "a new per-appearance id after Stop"


def test_the_filter_drops_the_entries_no_sensor_saw_lately(stack, rospy_node):
    """Bob walks out of every sensor's view (through the living room's door and east along the
    corridor, behind its wall) and stays there: the tracker coasts his track for its timeout
    (1 s), the filter drops it once no sensor saw him for its stale_after (0.5 s). (Not beside
    the dining table: the laser sees his legs there now and then between the table's and the
    chairs' legs.)"""
    session, procs = stack
    path = [[2.6, 2.6], [1.8, 2.9], [1.8, 4.9], [2.45, 5.2], [2.45, 6.15], [4.0, 6.15]]  # 6.1 m, 10 s
    t0 = scene(session, rospy_node, bob={"path": path, "speed": 0.6, "mode": "once", "shirt": BLUE})
    session.wait_sim(15.0)
    raw = {t: users for t, users in session.last_seen_log(t0, session.sim_now())}
    filtered = dict(session.filtered_log(t0, session.sim_now()))
    stale = [(t, pid) for t, users in raw.items() for pid, seen in users.items() if t - seen > 0.6]
    fresh = [(t, pid) for t, users in raw.items() for pid, seen in users.items() if t - seen < 0.3]
    ages = {}  # pid -> (first t, last t, the longest it went unseen)
    for t, users in sorted(raw.items()):
        for pid, seen in users.items():
            first, _, age = ages.get(pid, (t, t, 0.0))
            ages[pid] = (first, t, max(age, t - seen))
    summary = ", ".join(f"id {pid} from {a:.1f} to {b:.1f} s, unseen up to {age:.2f} s"
                        for pid, (a, b, age) in ages.items())
    detail = (f"raw {len(raw)} messages ({summary}; started at {t0:.1f} s), filtered {len(filtered)}\n"
              f"{procs[-1].output(3000)}")
    assert fresh and stale, f"bob was tracked, then coasted unseen: {detail}"
    compared = [(t, pid) for t, pid in stale if t in filtered]
    assert compared, detail
    assert all(pid not in filtered[t] for t, pid in compared), detail
    assert all(pid in filtered[t] for t, pid in fresh if t in filtered), detail
