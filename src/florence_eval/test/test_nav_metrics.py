"""bench/nav.py's metrics (florence_eval.nav_metrics) and the shipped navigation parameters
(florence_eval.nav_config), no ROS master.

The body clearance is what backs "collisions 0" with a margin, so it must see the table top the
laser passes under."""

import math
import os
import time

import numpy as np
import pytest
from florence_eval.metrics import Stopwatch, cpu_seconds
from florence_eval.nav_config import move_base_params

from florence_eval import nav_metrics

pytestmark = pytest.mark.unit


@pytest.fixture(scope="module")
def world_and_body():
    return nav_metrics.load_scene(), nav_metrics.robot_body()


def track(*xy):
    return np.array([[0.0, x, y, 0.0, 0.0, 0.0] for x, y in xy])


# --- the robot's body against the world ------------------------------------------------------------
def test_robot_body_is_the_create_up_to_the_kinect(world_and_body):
    _, (radius, height) = world_and_body
    assert 0.15 < radius < 0.2  # the Create's body
    assert height > 0.71  # taller than the dining table: its top stops the robot


def test_body_clearance_sees_the_table_top_and_not_only_its_legs(world_and_body):
    scene, (radius, height) = world_and_body
    # the dining table: top x 2.8..4.0, y 3.4..4.2, 0.71 m up; legs at (3.4 +- 0.55, 3.8 +- 0.35)
    east = nav_metrics.body_clearance(scene, track((4.0 + radius + 0.10, 3.8)), radius, height)
    assert east == pytest.approx(0.10, abs=1e-6)  # from the top's edge; the legs are further off
    under = nav_metrics.body_clearance(scene, track((4.0 + radius + 0.10, 3.8), (3.4, 3.6)), radius, height)
    assert under < 0.0  # under the top: overlapping it
    assert nav_metrics.body_clearance(scene, track((4.0 + radius + 0.10, 3.8)), radius, 0.5) > 0.14  # legs only
    assert nav_metrics.body_clearance(scene, np.empty((0, 6)), radius, height) is None


def test_clearance_spread_skips_legs_without_a_track():
    spread = nav_metrics.clearance_spread([0.3, None, 0.1, 0.2])
    assert spread["min"] == pytest.approx(0.1) and spread["median"] == pytest.approx(0.2)
    assert nav_metrics.clearance_spread([None]) is None


# --- people (issue 21) ------------------------------------------------------------------------------
def test_people_near_counts_the_least_distance_while_driving():
    # the robot drives east along y 0 at 0.5 m/s for 2 s, then stands; a person walks toward where
    # it stands and stops 0.4 m from it
    t = np.arange(0.0, 4.0, 0.1)
    x = np.minimum(0.5 * t, 1.0)
    v = np.where(t < 2.0, 0.5, 0.0)
    track = np.column_stack([t, x, np.zeros_like(t), np.zeros_like(t), v, np.zeros_like(t)])
    tp = np.arange(0.0, 4.01, 0.5)
    person = np.column_stack([tp, np.maximum(3.0 - 0.8 * tp, 1.4), np.zeros_like(tp)])
    near = nav_metrics.people_near(track, {"bob": person}, 0.17, {"bob": 0.2})
    assert near["person_distance_m"] == pytest.approx(0.4, abs=1e-6)  # at rest: not while driving
    driving = np.hypot(x - np.interp(t, tp, person[:, 1]), 0.0)[v >= 0.03].min()
    assert near["person_distance_driving_m"] == pytest.approx(driving)
    assert near["person_clearance_m"] == pytest.approx(0.4 - 0.17 - 0.2)
    assert near["person_nearest_driving_at"][4] == "bob"
    # nobody recorded, or a person only before the track began
    assert nav_metrics.people_near(track, {}, 0.17)["person_distance_m"] is None
    late = {"x": np.array([[10.0, 0.0, 0.0], [11.0, 0.0, 0.0]])}
    assert nav_metrics.people_near(track, late, 0.17)["person_distance_m"] is None


def test_people_near_says_who_closed_in():
    # the robot drives east at 0.2 m/s, then stands; Bob walks west toward it at 0.4 m/s throughout
    t = np.arange(0.0, 3.0, 0.1)
    v = np.where(t < 2.0, 0.2, 0.0)
    x = np.minimum(0.2 * t, 0.4)
    track = np.column_stack([t, x, np.zeros_like(t), np.zeros_like(t), v, np.zeros_like(t)])
    tp = np.arange(0.0, 3.01, 0.25)
    bob = np.column_stack([tp, 3.0 - 0.4 * tp, np.zeros_like(tp)])
    near = nav_metrics.people_near(track, {"bob": bob}, 0.17)
    assert near["person_nearest_driving_closing_mps"] == pytest.approx([0.2, 0.4], abs=1e-3)
    # the robot driving west, away from him: its own speed toward him is negative
    away = track.copy()
    away[:, 3] = np.pi
    assert nav_metrics.people_near(away, {"bob": bob}, 0.17)["person_nearest_driving_closing_mps"][0] \
        == pytest.approx(-0.2, abs=1e-3)
    # summarised: a leg under 0.5 m in which the robot closed in, and one in which only the person did
    legs = [{"state": "SUCCEEDED", "ratio": 1.0, "collisions": 0, "body_clearance_m": 0.1,
             "person_distance_driving_m": 0.45, "person_nearest_driving_closing_mps": closing,
             **dict.fromkeys(("ratio_with_turns", "ratio_to_rest", "rest_s", "time_s", "start_s", "end_s",
                              "end_error_m", "end_yaw_error_rad", "rest_error_m", "driving_s",
                              "turning_in_place_s", "standing_s"), 1.0)}
            for closing in ([0.2, 0.0], [0.0, 0.5])]
    summary = nav_metrics.summarise(legs)
    assert summary["legs_nearer_than_0_5_m_driving"] == 2
    assert summary["legs_nearer_than_0_5_m_robot_closing"] == 1
    assert summary["legs_nearer_than_0_5_m_robot_approached"] == 0  # no shares recorded (older runs)
    for leg, shares in zip(legs, ([0.3, 0.1], [0.1, 0.3]), strict=True):
        leg["person_nearest_driving_approach_m"] = shares
    assert nav_metrics.summarise(legs)["legs_nearer_than_0_5_m_robot_approached"] == 1


def test_approach_shares_split_the_distance_lost_between_robot_and_person():
    # Bob walks west at 0.4 m/s from x 3; the robot drives east at 0.2 m/s for 2 s, then stands
    t = np.arange(0.0, 6.0, 0.05)
    robot = np.column_stack([np.minimum(0.2 * t, 0.4), np.zeros_like(t)])
    bob = np.column_stack([np.maximum(3.0 - 0.4 * t, 0.9), np.zeros_like(t)])
    end = len(t) - 1  # 0.5 m apart
    robot_m, person_m = nav_metrics.approach_shares(robot, bob, end, start_distance=0.8)
    # 0.8 m apart at 4.5 s, long after the robot stopped: over that stretch only he moved
    assert robot_m == pytest.approx(0.0, abs=1e-9) and person_m == pytest.approx(0.3, abs=0.021)  # one step of his
    # from the start (never 5 m apart): the robot took off 0.4 m, he 2.1 m, together 3.0 - 0.5
    robot_m, person_m = nav_metrics.approach_shares(robot, bob, end, start_distance=5.0)
    assert robot_m == pytest.approx(0.4, abs=1e-3) and person_m == pytest.approx(2.1, abs=1e-3)
    # the robot sliding past a person who stands: all of it the robot's
    past = np.column_stack([np.linspace(-1.0, 0.0, 21), np.full(21, -0.4)])
    still = np.zeros((21, 2))
    robot_m, person_m = nav_metrics.approach_shares(past, still, 20, start_distance=2.0)
    assert person_m == pytest.approx(0.0, abs=1e-12)
    assert robot_m == pytest.approx(math.hypot(-1.0, -0.4) - 0.4, abs=1e-3)  # rounded to the mm
    # a person who walks up from the side to a robot driving on: hers
    side = np.column_stack([np.zeros(21), np.linspace(-1.0, -0.4, 21)])
    ahead = np.column_stack([np.linspace(0.0, 0.02, 21), np.zeros(21)])
    robot_m, person_m = nav_metrics.approach_shares(ahead, side, 20)
    assert person_m > 0.35 and abs(robot_m) < 0.01


def test_leg_record_body_clearance_counts_people(world_and_body):
    scene, body = world_and_body
    track = np.array([[0.0, 1.2, 3.0, 0.0, 0.2, 0.0], [0.5, 1.3, 3.0, 0.0, 0.2, 0.0]])
    people = {"alice": np.array([[0.0, 1.8, 3.0], [1.0, 1.8, 3.0]])}
    leg = nav_metrics.leg_record((1.3, 3.0, 0.0), "SUCCEEDED", "", 0.5, 0.1, 0.1, 0.0, track, 0.0, 0, [], scene, body,
                                 people=people, radii={"alice": 0.2})
    assert leg["person_distance_driving_m"] == pytest.approx(0.5)
    assert leg["body_clearance_m"] == pytest.approx(0.5 - body[0] - 0.2)  # the person, nearer than any wall
    assert leg["world_clearance_m"] > leg["body_clearance_m"]
    # where she was at every kept row of the track, for a look at the leg later
    assert leg["people_at_track"] == {"alice": [[1.8, 3.0]]} and len(leg["track"]) == 1
    assert leg["person_nearest_driving_approach_m"] == [0.1, 0.0]  # from 0.6 m: the robot's 0.1 m
    # 0.1 m at 0.5 m/s (0.2 s) takes 2 sqrt(0.1 / 1.0) s from rest to rest, no turn
    assert leg["ratio_floor"] == pytest.approx(2.0 * math.sqrt(0.1) / 0.2)
    summary = nav_metrics.summarise([leg])
    assert summary["legs_nearer_than_0_5_m_driving"] == 0
    assert summary["verdicts"]["person_distance_driving_m"] is True
    assert summary["verdicts"]["body_clearance_m"] is True and summary["verdicts"]["success_rate"] is True


def test_ideal_planner_plans_round_the_table_top_in_the_true_world():
    from florence_eval.nav_config import IdealPlanner

    ideal = IdealPlanner()
    west, east = (1.8, 3.8, 0.0), (4.5, 3.8, 0.0)  # either side of the dining table (top x 2.8..4.0)
    xy = ideal.plan(west, east)
    assert xy is not None
    length = float(np.sum(np.hypot(*np.diff(xy, axis=0).T)))
    assert length > 2.7 + 0.5  # round the top and its chairs, not under it between its legs
    assert ideal.plan(west, (3.4, 3.8, 0.0)) is None  # under the top: no way in the true world
    assert ideal.grid.data.shape == (220, 180)


# --- ideal times --------------------------------------------------------------------------------------
@pytest.mark.parametrize(("angle", "expected"), [
    (0.0, 0.0),
    (1.0, 2.0),  # within max_vel^2 / acc = 2.25 rad: accelerate half-way, brake the rest (2 sqrt(1 / 1.0))
    (math.pi, 1.5 + math.pi / 1.5),  # reaches 1.5 rad/s: ramp up and down (1.5 s) plus the rest at speed
    (2.0 * math.pi + 1.0, 2.0),  # wrapped
    (-1.0, 2.0),
])
def test_turn_time_from_rest_to_rest(angle, expected):
    assert nav_metrics.turn_time(angle) == pytest.approx(expected)


@pytest.mark.parametrize(("length", "expected"), [
    (0.0, 0.0),
    (0.16, 0.8),  # below max_vel^2 / acc = 0.25 m: accelerate half-way, brake the rest (2 sqrt(0.16 / 1.0))
    (2.0, 4.5),  # at 0.5 m/s: 4 s, plus 0.5 s lost ramping up and down
])
def test_drive_time_from_rest_to_rest(length, expected):
    assert nav_metrics.drive_time(length) == pytest.approx(expected)


def test_floor_ratios_of_legs_goal_to_goal():
    def straight(start, goal):  # the shortest path: a straight line, except into the wall at x > 9
        return None if goal[0] > 9.0 else np.linspace(start[:2], goal[:2], 11)

    goals = [(2.0, 0.0, 0.0), (10.0, 0.0, 0.0), (2.2, 0.0, 0.0), (2.0, 2.0, math.pi / 2)]
    ratios = nav_metrics.floor_ratios(straight, goals, (0.0, 0.0, 0.0), 5)
    # (2 m east, no turn: 4.5 / 4); unreachable and 0.2 m skipped; (2 m north from (2, 0, 0): a quarter
    # turn onto it, none at the end)
    assert ratios == pytest.approx([4.5 / 4.0, (4.5 + nav_metrics.turn_time(math.pi / 2)) / 4.0])
    assert nav_metrics.floor_ratios(straight, goals, (0.0, 0.0, 0.0), 1) == pytest.approx([4.5 / 4.0])


def test_plan_length_and_turns():
    xy = np.column_stack([np.linspace(0.0, 2.0, 41), np.zeros(41)])  # 2 m along x
    length, turns = nav_metrics.plan_length_and_turns(xy, (0.0, 0.0, math.pi / 2), (2.0, 0.0, 0.0))
    assert length == pytest.approx(2.0)
    assert turns == pytest.approx(nav_metrics.turn_time(math.pi / 2))  # onto the plan; the goal yaw is its heading


# --- one leg --------------------------------------------------------------------------------------------
def straight_leg():
    """0.1 s rows: 1 s standing, 2 s at 0.5 m/s along x, 1 s turning on the spot, 1 s standing."""
    rows = []
    x = yaw = 0.0
    for k in range(50):
        t = 0.1 * k
        v = 0.5 if 1.0 <= t < 3.0 else 0.0
        w = 1.0 if 3.0 <= t < 4.0 else 0.0
        rows.append((t, x, 0.0, yaw, v, w))
        x += 0.1 * v
        yaw += 0.1 * w
    return np.array(rows)


def test_time_breakdown_rest_and_phases():
    leg = straight_leg()
    parts = nav_metrics.time_breakdown(leg)
    assert parts["driving_s"] == pytest.approx(2.0) and parts["turning_in_place_s"] == pytest.approx(1.0)
    assert parts["standing_s"] == pytest.approx(1.9)
    assert nav_metrics.time_to_rest(leg, 0.5) == pytest.approx(3.5)  # moving until 4.0 s
    phases = nav_metrics.leg_phases(leg, (1.0, 0.0, 1.0))
    assert phases["start_s"] == pytest.approx(2.1)  # 0.5 m from the start at 2.1 s
    assert phases["end_s"] == pytest.approx(4.9 - 1.5)  # within 0.8 m of the goal (x > 0.2 m) from 1.5 s
    distance, yaw_error = nav_metrics.goal_error(leg, (1.0, 0.0, 1.0 + 2.0 * math.pi))
    assert distance == pytest.approx(0.0, abs=1e-9) and yaw_error == pytest.approx(0.0, abs=1e-9)


def test_spin_in_place_is_the_largest_turn_without_moving():
    leg = straight_leg()  # 1 rad on the spot after driving 1 m
    assert nav_metrics.spin_in_place(leg) == pytest.approx(1.0, abs=0.05)
    t = np.arange(0.0, 10.0, 0.1)  # 1.5 rad/s for 10 s, the centre wobbling 2 cm: 15 rad
    spin = np.column_stack([t, 0.02 * np.sin(t), np.zeros_like(t), np.asarray([math.remainder(1.5 * v, 2 * math.pi)
                                                                                for v in t]), 0 * t, 1.5 + 0 * t])
    assert nav_metrics.spin_in_place(spin) == pytest.approx(1.5 * 9.9, rel=1e-6)
    moved = spin.copy()
    moved[50:, 1] += 0.5  # driven off half way: two stays of about 7.4 rad each
    assert nav_metrics.spin_in_place(moved) == pytest.approx(1.5 * 4.9, rel=1e-6)
    assert nav_metrics.spin_in_place(spin[:1]) == 0.0


def test_summary_over_legs():
    reached = {"state": "SUCCEEDED", "goal": [1.0, 0.0, 0.0], "text": "", "collisions": 0, "body_clearance_m": 0.1,
               "ratio": 1.2, "ratio_with_turns": 1.1, "ratio_to_rest": 1.3, "rest_s": 5.0, "time_s": 4.0,
               "start_s": 1.5, "end_s": 2.0, "end_error_m": 0.1, "end_yaw_error_rad": 0.2, "rest_error_m": 0.3,
               "driving_s": 3.0, "turning_in_place_s": 0.5, "standing_s": 0.5}
    failed = {**reached, "state": "ABORTED", "text": "no path", "collisions": 1, "body_clearance_m": 0.0}
    summary = nav_metrics.summarise([reached, failed])
    assert summary["pairs"] == 2 and summary["succeeded"] == 1 and summary["success_rate"] == 0.5
    assert summary["collisions"] == 1 and summary["body_clearance_m"]["min"] == 0.0
    assert summary["time_ratio_median"] == 1.2 and summary["rest_after_outcome_s"]["max"] == 1.0
    assert summary["time_ratio_floor_median"] is None  # legs recorded before the floor: none
    floored = nav_metrics.summarise([{**reached, "ratio_floor": 1.5}, {**reached, "ratio_floor": 1.3}, failed])
    assert floored["time_ratio_floor_median"] == pytest.approx(1.4)  # over the goals reached
    assert summary["legs_spinning_over_a_turn"] == 0  # legs without the figure count as not spinning
    spun = nav_metrics.summarise([{**reached, "spin_in_place_rad": 7.0}, {**reached, "spin_in_place_rad": 3.0}])
    assert spun["legs_spinning_over_a_turn"] == 1
    assert spun["spin_in_place_max_turns"] == pytest.approx(7.0 / 2 / math.pi)
    assert summary["goal_error"]["rest_error_m"]["beyond_tolerance"] == 1  # 0.3 m > xy_goal_tolerance 0.25 m
    assert summary["time_share"]["driving_s"] == pytest.approx(0.75)
    assert summary["failures"] == [{"goal": [1.0, 0.0, 0.0], "state": "ABORTED", "text": "no path"}]
    assert nav_metrics.summarise([])["time_ratio_median"] is None


# --- what ships and what a bench measures -------------------------------------------------------------------
def test_move_base_params_are_the_launch_files():
    params = move_base_params()
    assert params["planner_frequency"] == 1.0 and params["controller_frequency"] == 5.0
    assert params["global_costmap"]["inflation_radius"] == 0.4
    assert params["local_costmap"]["width"] == 4.0 and params["local_costmap"]["scan"]["data_type"] == "LaserScan"
    assert params["TrajectoryPlannerROS"]["max_vel_x"] == nav_metrics.MAX_VEL_X
    assert params["TrajectoryPlannerROS"]["max_rotational_vel"] == nav_metrics.MAX_VEL_TH
    assert params["TrajectoryPlannerROS"]["xy_goal_tolerance"] == nav_metrics.XY_GOAL_TOLERANCE


def test_cpu_seconds_of_this_process():
    assert cpu_seconds(os.getpid()) > 0.0


def test_stopwatch_keeps_wall_and_cpu_time_apart():
    watch = Stopwatch()
    with watch:
        time.sleep(0.05)  # waiting: wall time, no CPU time (sleep may wake a fraction of a ms early by perf_counter)
    with watch:
        end = time.thread_time() + 0.03
        while time.thread_time() < end:  # working: CPU time too
            pass
    s = watch.summary()
    assert s["n"] == 2
    assert watch.wall_ms[0] >= 49.0 and watch.cpu_ms[0] < 10.0
    assert watch.cpu_ms[1] >= 25.0 and watch.wall_ms[1] >= watch.cpu_ms[1] - 1.0
    assert s["p99_ms"] >= 49.0 and s["cpu_p99_ms"] >= 25.0
    assert Stopwatch().summary() == {"n": 0}


def test_room_goals_go_round_the_named_hotspots():
    goals = nav_metrics.room_goals(["bathroom", "bedroom"], 5)
    assert goals.shape == (5, 3)
    assert goals[0] == pytest.approx((6.5, 7.7, math.pi / 2), abs=1e-6)  # maps/apartment/rooms.yaml
    assert goals[1] == pytest.approx((1.2, 7.6, math.pi / 2), abs=1e-6)
    assert goals[2] == pytest.approx(goals[0]) and goals[3] == pytest.approx(goals[1])
    with pytest.raises(ValueError, match="known: bathroom, bedroom, corridor, kitchen, living_room"):
        nav_metrics.room_goals(["bathroom", "attic"], 2)
    with pytest.raises(ValueError):
        nav_metrics.room_goals([], 2)
