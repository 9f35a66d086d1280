"""The robot enablers and the collision monitor in florence_sim's apartment with the real user tracker
(enablers_sim.launch: the simulator, the filters with the monitor, the Kinect's fake laser, map_server,
amcl, user_tracker.launch, follow_me, approach_me), driven by actionlib clients and teleop as a user
would, judged against the simulator's ground truth: following a person through a doorway at 0.3 and
0.5 m/s (the robot's top speed); a person who leaves (removed) is searched for, then ABORTED; cancel stops at once;
approaching a standing person from the front, the side and at 45 degrees; the monitor stops teleop
at a wall and follow_me at a chair, and lets the robot turn away.

One stack for the module (its start-up costs most); each test sets its own scene. Judged in
simulated time (ground truth stamps).

(Here, not in the enablers' packages: florence_eval depends on them.)"""

import math

import numpy as np
import pytest

from florence_common.processes import wait_for

pytestmark = [pytest.mark.scenario, pytest.mark.slow]

RTF = 1.0  # real time: the monitor plans with wall-time latencies (0.2 s), which 2x doubles in simulated time
LOST_TIMEOUT = 5.0  # [s] follow_me's ~lost_timeout here (10 s by default)
RED, BLUE = [0.85, 0.1, 0.1], [0.1, 0.3, 0.85]
# living room -> corridor through the door at x 2.0..2.9 (y 5.5), then east along the corridor
DOORWAY_PATH = [[1.2, 3.8], [2.45, 4.9], [2.45, 6.15], [4.5, 6.15]]
START = (1.2, 2.0, math.pi / 2)  # 1.8 m behind the person: the Kinect sees their shirt


@pytest.fixture(scope="module")
def sim(ros_master, rospy_node, tf_buffer):
    import rosgraph
    from florence_eval.enablers_session import EnablersSession, launch_stack

    master = rosgraph.Master("/pytest")
    had_sim_time = master.hasParam("/use_sim_time")
    for stale in ("/amcl", "/follow_me_node", "/approach_me_node", "/collision_monitor"):
        if master.hasParam(stale):
            master.deleteParam(stale)
    tf_buffer.clear()
    proc = launch_stack(ros_master, (1.6, 2.1, math.pi / 2), real_time_factor=RTF, seed=3, lost_timeout=LOST_TIMEOUT)
    session = EnablersSession()
    try:
        session.wait_ready()
        rospy_node.wait_for_service("/user_tracker_ni_node/Start", 60)
        yield session, proc
    finally:
        session.close()
        proc.stop()
        if not had_sim_time and master.hasParam("/use_sim_time"):
            master.deleteParam("/use_sim_time")
        tf_buffer.clear()


def detail(session, proc):
    return f"\n----- stack output (tail) -----\n{proc.output(5000)}"


# speed [m/s] -> (largest distance error [m], least share of the walk the right person was followed)
FOLLOW_BOUNDS = {0.3: (0.4, 0.9), 0.5: (1.25, 0.85)}


@pytest.mark.parametrize("speed", sorted(FOLLOW_BOUNDS))
def test_follows_a_person_through_a_doorway(sim, speed):
    """Through the doorway where the person went, never nearer than 0.45 m, the right person followed,
    never left behind, and at 1 m when they stop. How near the desired distance it keeps is
    bench/enablers.py's to measure. At 0.3 m/s the robot has speed to spare: 0.15 m at most (3 runs,
    27 Nov). At 0.5 m/s, the Create's top speed, what it loses round the corners is never made up: 0.76-1.17 m
    (14 runs, 27 Nov; 1.0 m was the bound and failed 3 times), she is at most 2.25 m ahead, well within what
    the tracker sees; turning into the corridor in the doorway it may lose sight of her for a moment (the
    laser sees +-90 degrees) and find her again: 89.4 % of the walk once in 14 runs, 93.8 % once (the tracker
    dropped her standing 1.1 m ahead and the search drove up to her, as it no longer does), 98.7-100 % in the
    12 others."""
    session, proc = sim
    result = session.follow_trial(START, "alice", DOORWAY_PATH, speed, RED)
    session.follow_client.cancel_goal()
    track = np.asarray(result.pop("robot_track"))
    result.pop("person_track")
    info = f"{result}{detail(session, proc)}"
    assert result["state"] == "ACTIVE", f"the goal ended: {info}"
    assert np.max(track[:, 2]) > 5.8, f"the robot did not go through the doorway: {info}"
    assert result["collisions"] == 0, info
    assert result["min_distance_m"] >= 0.45, info
    largest, kept = FOLLOW_BOUNDS[speed]
    assert result["kept_fraction"] >= kept, info
    assert result["max_error_m"] <= largest, info
    assert abs(result["final_distance_m"] - 1.0) < 0.2, info


def test_a_person_who_leaves_is_searched_for_then_aborted(sim):
    session, proc = sim
    session.scene((1.0, 6.15, 0.0), bob={"pose": [2.8, 6.15, 0.0], "shirt": BLUE})  # the corridor
    session.follow("bob")
    session.set_person("bob", path=[[2.8, 6.15], [6.0, 6.15]], speed=0.4, mode="once", shirt=BLUE)
    session.wait_sim(3.0)
    session.remove_person("bob")
    gone = session.sim_now()
    state, text = session.wait_result(session.follow_client, LOST_TIMEOUT + 8.0)
    took = session.sim_now() - gone
    texts = [s for _, s in session.states_log("follow_me", gone)]
    info = f"{state} {text!r} after {took:.1f} s; states {texts[:3]} ... {texts[-3:]}{detail(session, proc)}"
    assert state == "ABORTED" and "person lost" in text, info
    assert any("searching for" in s for s in texts), info
    assert LOST_TIMEOUT <= took <= LOST_TIMEOUT + 3.0, info
    assert session.wait_still(), "the robot did not stop"


def test_cancel_stops_within_0_2_s(sim):
    session, _ = sim
    session.scene(START, alice={"pose": [*DOORWAY_PATH[0], math.pi / 2], "shirt": RED})
    session.follow("alice", max_lin_speed=0.3)
    session.set_person("alice", path=[DOORWAY_PATH[0], [1.2, 5.0]], speed=0.3, mode="once", shirt=RED)
    wait_for(lambda: (p := session.truth_log(session.sim_now() - 0.2)).size and np.all(
        np.hypot(*np.diff(p[:, 1:3], axis=0).T) > 0), 60, what="the robot moving")
    session.wait_sim(1.0)
    cancelled = session.sim_now()
    session.follow_client.cancel_goal()
    state, _ = session.wait_result(session.follow_client, 5.0)
    assert state == "PREEMPTED"
    session.wait_sim(1.5)
    zeros = [t for t, _, v, w in session.commands_log("monitor", cancelled) if (v, w) == (0.0, 0.0)]
    assert zeros and zeros[0] - cancelled <= 0.2, f"first zero command {zeros[:1]} after the cancel at {cancelled}"
    track = session.truth_log(cancelled)
    moved = np.hypot(track[:, 1] - track[-1, 1], track[:, 2] - track[-1, 2]) > 0.005
    stopped = track[np.flatnonzero(moved)[-1] + 1, 0] if moved.any() else cancelled
    # braking from 0.3 m/s at velocity_filter's 1 m/s^2 takes 0.3 s after the zero arrives
    assert stopped - cancelled <= 0.2 + 0.3 + 0.3, f"at rest {stopped - cancelled:.2f} s after the cancel"


@pytest.mark.parametrize("name, p2r, r2p", [("front", 0.0, 0.0), ("side", math.pi / 2, 0.3),
                                            ("45 degrees", -math.pi / 4, -0.3)])
def test_approaches_a_standing_person(sim, name, p2r, r2p):
    session, proc = sim
    # east of the coffee table: open floor round the person
    result = session.approach_trial((2.6, 2.1, -0.1), "alice", (4.2, 1.9), RED, 0.6, p2r, r2p)
    result.pop("robot_track")
    info = f"{name}: {result}{detail(session, proc)}"
    print(f"{name}: {result['state']}, {result['position_error_m']:.3f} m and {result['heading_error_rad']:.3f} rad "
          f"off by ground truth, least distance {result['least_distance_m']:.2f} m")
    assert result["state"] == "SUCCEEDED", info
    assert result["position_error_m"] <= 0.12 and result["heading_error_rad"] <= 0.12, info
    assert result["collisions"] == 0 and result["least_distance_m"] > 0.5, info


def test_the_monitor_stops_teleop_at_a_wall_and_lets_the_robot_turn_away(sim):
    from florence_eval import nav_metrics

    session, proc = sim
    t0 = session.scene((0.9, 2.5, math.pi))  # facing the west wall, 0.85 m away
    collisions = session.collisions
    session.teleop(0.3, 0.0, 5.0)
    scene_ = nav_metrics.load_scene()
    radius, height = nav_metrics.robot_body()
    truth = session.truth_log(t0)  # read once: the log grows while we look
    track = np.column_stack([truth, np.zeros((len(truth), 2))])
    gap = nav_metrics.body_clearance(scene_, track, radius, height)
    info = f"gap {gap:.3f} m at x {session.pose()[0]:.2f}{detail(session, proc)}"
    print(f"teleop at the wall: stopped {gap:.3f} m from it (ground truth)")
    assert session.collisions == collisions, info
    # not too early either: the monitor's stop_distance is 0.06 m; it plans braking at 0.5 m/s^2 while
    # velocity_filter brakes at 1.0, and judges on 10 Hz scans with the laser's noise: 0.085-0.105 m in 5 runs
    # (26 Nov), so 0.12 m, not the 0.10 m that failed once
    assert 0.0 < gap <= 0.12, info
    assert any(s == "stop" for _, s, *_ in session.monitor_log(t0)), info
    t1 = session.sim_now()
    session.teleop(0.0, 1.0, 2.0)  # turning in place passes
    yaw = np.unwrap(session.truth_log(t1)[:, 3])
    assert yaw[-1] - yaw[0] > 1.0, f"turned {yaw[-1] - yaw[0]:.2f} rad"
    for _ in range(20):  # on round until it faces away from the wall (east)
        if abs(session.pose()[2]) < 0.4:
            break
        session.teleop(0.0, 0.8, 0.3)
    x = session.pose()[0]
    session.teleop(0.3, 0.0, 2.0)  # and driving away
    assert session.pose()[0] - x > 0.3, f"moved {session.pose()[0] - x:.2f} m away, heading {session.pose()[2]:.2f}"
    assert session.collisions == collisions


def test_the_monitor_stops_follow_me_at_a_chair(sim):
    from florence_eval import nav_metrics

    session, proc = sim
    # the west dining chair (seat 0.42 m square at 0.45 m, centre (2.45, 3.8)) between the robot and
    # a person 2.5 m ahead: follow_me drives at them to be 1 m away, i.e. into the chair
    t0 = session.scene((2.45, 2.2, math.pi / 2), bob={"pose": [2.45, 4.75, -math.pi / 2],
                                                                    "shirt": BLUE})
    collisions = session.collisions
    session.follow("bob")
    session.wait_sim(8.0)
    state = session.follow_client.get_state()
    session.follow_client.cancel_goal()
    track = session.truth_log(t0)
    gap = nav_metrics.body_clearance(nav_metrics.load_scene(), np.column_stack([track, np.zeros((len(track), 2))]),
                                     *nav_metrics.robot_body())
    stops = [r for r in session.monitor_log(t0) if r[1] == "stop"]
    info = f"state {state}, y {session.pose()[1]:.2f}, gap {gap:.3f} m, stops {len(stops)}{detail(session, proc)}"
    print(f"follow_me at the chair: least gap {gap:.3f} m to the seat (ground truth), stopped at y "
          f"{session.pose()[1]:.3f}")
    assert state == 1, info  # still following: the person is there
    assert session.collisions == collisions and gap > 0.0, info
    assert stops and session.pose()[1] > 2.2 + 0.5, info  # it drove, then was stopped
    assert session.pose()[1] < 3.59 - 0.17, info  # short of the seat
