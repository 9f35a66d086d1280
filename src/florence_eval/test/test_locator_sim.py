"""florenceLocator on the real stack in florence_sim (turtlebot_2dnav_control.launch sim:=true,
user_tracker.launch, florence_locator.launch), called as a client would and judged by the
simulator's ground truth: gotoRoom to every room, getRobotPosRoom in each, gotoUser to a user
sitting in the living room from the kitchen, setUserPosRoom("bedroom") from a home sensor and
gotoUser finding the user there, the user absent (a full turn in two places, ABORTED), manualOverride stopping
the robot mid-route and teleop driving it then.

One stack for the module (its start-up costs most); the tests run in file order. A test that needs the
robot somewhere carries it there (florence_sim and amcl told), so one that fails leaves the next ones
their own start. Real time (RTF 1): at 2x, move_base's 5 Hz cycle and the hops between nodes take twice
as much simulated time as on the robot. The long variants (random placements) are bench/locator.py's.

(Here, not in florence_locator's tests: florence_eval depends on florence_locator.)"""

import math
import time

import numpy as np
import pytest

from florence_common import angles
from florence_common.processes import ProcessError, wait_for

pytestmark = [pytest.mark.scenario, pytest.mark.slow]

START = (6.5, 7.7, 1.5707963)  # the bathroom's hotspot
RTF = 1.0
# the tour ends in the kitchen, where the gotoUser test starts
TOUR = ["bathroom", "bedroom", "corridor", "living_room", "kitchen"]
ALICE = {"pose": [3.0, 2.4, 2.8], "posture": "sitting", "shirt": [0.85, 0.1, 0.1]}  # living room, facing WNW
ALICE_BEDROOM = {"pose": [1.5, 8.8, -1.8], "posture": "sitting", "shirt": [0.85, 0.1, 0.1]}  # by the bed
DISTANCE, DISTANCE_TOL, FACING_TOL = 0.5, 0.15, math.radians(20)


@pytest.fixture(scope="module")
def stack(ros_master, rospy_node, tf_buffer):
    import rosgraph
    from florence_eval.locator_session import LocatorSession, launch_stack, stop_stack

    master = rosgraph.Master("/pytest")
    had_sim_time = master.hasParam("/use_sim_time")
    for stale in ("/amcl", "/move_base"):  # parameters an earlier test's nodes stored on this session master
        if master.hasParam(stale):
            master.deleteParam(stale)
    tf_buffer.clear()
    procs = launch_stack(ros_master, START, real_time_factor=RTF, seed=3)
    session = LocatorSession()
    try:
        session.wait_ready()
        session.set_person("alice", **ALICE)
        yield session, procs
    finally:
        session.set_override(False)
        session.close()
        stop_stack(procs)
        if not had_sim_time and master.hasParam("/use_sim_time"):
            master.deleteParam("/use_sim_time")
        tf_buffer.clear()


def hotspot(session, room):
    spot = session.call("getHotspot", room)
    return spot.x, spot.y, spot.phi


def dump(procs, last=2):
    """The output's tail of the ``last`` processes launched (the navigation stack is the first)."""
    return "\n".join(f"\n----- {p.name} (tail) -----\n{p.output(5000)}" for p in procs[-last:])


def goto_user_and_judge(session, procs, room):
    """gotoUser, which must end SUCCEEDED beside alice in ``room``: 0.5 +/- 0.15 m from her, facing her
    within 20 deg, without a collision (ground truth). Returns (Approach, nearest person, detail)."""
    from florence_eval import locator_metrics

    t0 = session.sim_now()
    res, done, took = session.goto_user()
    assert res.success, res.message
    assert done.status == "SUCCEEDED", f"{done.message} after {took:.0f} s{dump(procs, last=len(procs))}"
    session.wait_sim(0.5)  # the robot at rest, its pose recorded
    result = locator_metrics.approach(session.robot(), session.person("alice"))
    nearest = locator_metrics.nearest_person(session.track(t0), session.people_log(t0))
    detail = f"{result.as_dict()}, nearest {nearest}, {took:.0f} s: {done.message}"
    print(f"gotoUser in {room}: {detail}")
    assert session.call("getRobotPosRoom").room == room, detail
    assert abs(result.distance - DISTANCE) <= DISTANCE_TOL, detail
    assert abs(result.facing_error) <= FACING_TOL, detail
    assert session.collisions == 0, detail
    return result, nearest, detail


def test_goto_room_reaches_every_room_and_get_robot_pos_room_agrees(stack):
    from florence_eval import locator_metrics

    session, procs = stack
    legs = []
    for room in TOUR:
        t0 = session.sim_now()
        res = session.call("gotoRoom", room)
        assert res.success, res.message
        done = session.wait_status({"SUCCEEDED", "ABORTED", "PREEMPTED"}, 150.0)
        took = round(session.sim_now() - t0, 1)
        session.wait_sim(0.5)  # at rest: the truth and the estimate of one pose
        spot = session.call("getHotspot", room)
        est = session.call("getRobotPosXYPhi")
        end = locator_metrics.arrival(session.robot(), (est.x, est.y), (spot.x, spot.y))
        legs.append((room, done.status, round(end.true_distance, 2), took))
        assert done.status == "SUCCEEDED", f"{legs}: {done.message}{dump(procs, last=len(procs))}"
        assert est.success and end.ok, f"{legs}: {end}{dump(procs)}"
        here = session.call("getRobotPosRoom")
        assert here.success and here.room == room, f"{legs}: getRobotPosRoom {here}"
        goal = session.call("getGoalPosRoom")
        assert goal.room == room
    assert session.collisions == 0, legs
    print(f"gotoRoom legs (room, state, error m, sim s): {legs}")


@pytest.mark.xfail(strict=False, reason=(
    "known defect (issue 20): the robot, seeing the seated user on its way in from the kitchen, may come up behind "
    "her in the living room's corner between the coffee table and a chair. approach_me_map tries her front for "
    "~front_timeout (45 s; ~use_facing on since 29 Nov), then the robot's side, which is her back. Here at real time "
    "it reached her front-left or front-right in 26 and 41 s (29 Nov, 07bb0d1 and 6f946c7; 4 of 4 before with "
    "~use_facing on), but make demo at 2x real time, the same seat, ran out of the 45 s in 4 days of 4 and ended "
    "behind her"))
def test_goto_user_sitting_in_the_living_room_from_the_kitchen(stack):
    session, procs = stack
    session.place_robot(hotspot(session, "kitchen"))
    assert session.call("getRobotPosRoom").room == "kitchen"
    assert session.call("setUserPosRoom", "living_room").success  # a home sensor: the user is there
    result, _nearest, detail = goto_user_and_judge(session, procs, "living_room")
    assert result.side_name != "behind", detail  # she faces the way the robot comes from
    user = session.call("getUserPosXYPhi")  # updated from what detect_users saw
    alice = session.person("alice")
    assert math.hypot(user.x - alice[0], user.y - alice[1]) < 0.3, (user, alice)


def test_set_user_pos_room_from_a_home_sensor_then_goto_user_finds_the_user_there(stack):
    session, procs = stack
    # from the living room's hotspot (the last test leaves the robot by the coffee table beside where alice sat,
    # from where move_base twice could not get away: a defect of its own, noted on issue 20, not this test's)
    session.place_robot(hotspot(session, "living_room"))
    session.set_person("alice", **ALICE_BEDROOM)
    res = session.call("setUserPosRoom", "bedroom")  # the user's pose was in the living room: moved
    assert res.success and "hotspot of bedroom" in res.message, res.message
    assert session.call("getUserPosRoom").room == "bedroom"
    again = session.call("setUserPosRoom", "bedroom")  # already there: the finer position is kept
    assert again.success and "already" in again.message
    goto_user_and_judge(session, procs, "bedroom")


def test_user_absent_aborts_after_a_full_turn_in_two_places(stack):
    import rospy
    from move_base_msgs.msg import MoveBaseActionGoal

    from florence_eval import locator_metrics

    session, procs = stack
    session.place_robot(hotspot(session, "bedroom"))
    assert session.call("setUserPosRoom", "bedroom").success
    session.remove_people()
    session.wait_sim(1.0)
    goals = []  # simulated times of move_base goals: the one to the second place
    sub = rospy.Subscriber("/move_base/goal", MoveBaseActionGoal, lambda m: goals.append(m.header.stamp.to_sec()))
    t0 = session.sim_now()
    try:
        res, done, took = session.goto_user()  # the user's room is the robot's: no drive, the search at once
    finally:
        sub.unregister()
    assert res.success and "already in bedroom" in res.message, res.message
    assert done.status == "ABORTED" and "found nobody in a full turn at" in done.message, f"{done.message}{dump(procs)}"
    assert len(goals) == 1, f"move_base goals at {goals} s"
    track = session.track(t0)
    start, end = track[0, 1:3], track[-1, 1:3]
    # the first search: a full turn counter-clockwise where the robot stood, without turning back and forth
    first = track[track[:, 0] < goals[0]]
    assert np.max(np.hypot(*(first[:, 1:3] - start).T)) < 0.15, "the robot moved in its first search"
    net, total = locator_metrics.turned(first, signed=True), locator_metrics.turned(first)
    detail = f"first search: turned {math.degrees(net):.0f} deg net, {math.degrees(total):.0f} deg in all"
    assert math.radians(330) <= net <= math.radians(400), detail
    assert total <= net + math.radians(60), detail
    # then a second place in the bedroom, away from the first, and a full turn there too
    moved = math.hypot(*(end - start))
    assert moved > 1.5 and session.call("getRobotPosRoom").room == "bedroom", f"moved {moved:.2f} m"
    arrived = np.flatnonzero(np.hypot(*(track[:, 1:3] - end).T) > 0.15)[-1]
    second = locator_metrics.turned(track[arrived:])
    assert second >= math.radians(330), f"turned {math.degrees(second):.0f} deg at the second place"
    assert " and (" in done.message, done.message  # both places named
    assert took < 150.0, f"the two searches took {took:.0f} s"
    print(f"user absent: {detail}; {moved:.2f} m to a second place, {math.degrees(second):.0f} deg there; "
          f"ABORTED after {took:.1f} simulated s")


def test_manual_override_stops_the_robot_within_a_second_and_teleop_drives_it(stack):
    from florence_eval import locator_metrics

    session, procs = stack
    # from the living room (open floor; carried to the bedroom's hotspot, between the bed and the wall, move_base
    # once found no trajectory that did not collide: noted on issue 20)
    session.place_robot(hotspot(session, "living_room"))
    assert session.call("gotoRoom", "kitchen").success
    # mid-route: driving at speed, not in a sharp turn (velocity_filter brakes a turn at 1 rad/s^2: a turn at
    # 1.5 rad/s takes 1.5 s to stop whoever asks)
    try:
        wait_for(lambda: session.motion[-1][4] > 0.25 and abs(session.motion[-1][5]) < 0.4, 120,
                 what="the robot under way")
    except ProcessError as exc:
        raise AssertionError(f"{exc}: {session.call('getStatus')}{dump(procs)}") from None
    session.set_override(True)
    t_override = session.sim_now()
    wait_for(lambda: session.call("getStatus").status == "ABORTED", 10, what="the activity aborted")
    session.wait_sim(2.0)
    track = session.track(t_override - 0.2)
    stopped = locator_metrics.time_to_stop(track, t_override)
    speeds = [(round(r[0] - t_override, 2), round(r[4], 2), round(r[5], 2)) for r in track[::5]]
    assert stopped is not None and stopped <= 1.0, f"stopped after {stopped} s: (t, v, w) {speeds}{dump(procs)}"
    print(f"manual override: at rest {stopped:.2f} simulated s after it, from v = {track[0, 4]:.2f} m/s")
    res = session.call("gotoRoom", "bedroom")
    assert not res.success and "manual override" in res.message
    # the person at the keyboard drives: teleop's input of the multiplexer
    before = session.robot()
    session.drive(0.0, 0.6, 2.0)
    after = session.robot()
    assert abs(angles.diff(after[2], before[2])) > 0.5, (before, after)
    session.set_override(False)
    time.sleep(0.5)
    assert session.call("gotoRoom", "kitchen").success
    done = session.wait_status({"SUCCEEDED", "ABORTED"}, 150.0)
    assert done.status == "SUCCEEDED", f"after the override: {done}{dump(procs, last=len(procs))}"
    assert session.collisions == 0
