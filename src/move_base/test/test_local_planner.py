"""Tests of move_base.local_planner (TrajectoryPlannerROS without ROS)."""

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from move_base.costmap_2d import LETHAL_OBSTACLE, Costmap2D
from move_base.footprint import pad_footprint, parse_footprint, transform_footprint
from move_base.local_planner import (
    NO_VALID_TRAJECTORY,
    TURNING_AWAY,
    LocalPlanner,
    clip_plan,
    goal_turn_times,
    prune_count,
)
from move_base.trajectory_planner import PlannerParams, failure_counts, failure_text, poses_are_free
from scipy import ndimage

from florence_common import angles

pytestmark = pytest.mark.unit

# The seed's files (turtlebot_control/config): footprint padded by footprint_padding, and
# base_local_planner_params.yaml with its old parameter names and its controller_frequency.
_CONFIG = Path(__file__).resolve().parents[2] / "turtlebot_control" / "config"
_COMMON = yaml.safe_load((_CONFIG / "costmap_common_params.yaml").read_text())
_LOCAL = yaml.safe_load((_CONFIG / "base_local_planner_params.yaml").read_text())
FOOTPRINT = pad_footprint(parse_footprint(_COMMON["footprint"]), _COMMON["footprint_padding"])
SEED = {**_LOCAL["TrajectoryPlannerROS"], "controller_frequency": _LOCAL["controller_frequency"]}
INSCRIBED = 0.17  # [m]
CIRCUMSCRIBED = math.hypot(0.17, 0.17)  # [m]


def planner(**over):
    d = dict(SEED)
    d.update(over)
    return LocalPlanner(PlannerParams.from_dict(d), FOOTPRINT, INSCRIBED, CIRCUMSCRIBED)


def line_plan(x0, y0, x1, y1, yaw_end=None, step=0.05):
    n = max(2, round(math.hypot(x1 - x0, y1 - y0) / step) + 1)
    yaw = math.atan2(y1 - y0, x1 - x0)
    poses = np.column_stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n), np.full(n, yaw)])
    if yaw_end is not None:
        poses[-1, 2] = yaw_end
    return poses


def inflated(lethal_mask, resolution, inscribed=INSCRIBED, inflation_radius=0.40, scaling=10.0):
    """Costmap costs from lethal cells with costmap_2d's inflation formula (test reference)."""
    d = ndimage.distance_transform_edt(~lethal_mask) * resolution
    cost = np.where(d <= inflation_radius, 252.0 * np.exp(-scaling * (d - inscribed)), 0.0)
    cost = np.where(d <= inscribed, 253, np.floor(np.minimum(cost, 252)))
    cost = np.where(lethal_mask, LETHAL_OBSTACLE, cost)
    return cost.astype(np.uint8)


# --- goal tolerances ---------------------------------------------------------------------------

def test_goal_reached_within_both_tolerances():
    cm = Costmap2D(100, 100, 0.1)
    lp = planner()
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=0.0)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.8, 5.1, 0.25), (0.0, 0.0, 0.0), plan)
    assert ok and cmd == (0.0, 0.0, 0.0) and lp.is_goal_reached()
    assert "reached" in reason
    lp.set_plan(plan)
    assert not lp.is_goal_reached()


def _reached_while_turning(lp, yaw, vth, goal_yaw=0.0):
    """(reached, command) of one cycle at the goal position, ``yaw`` [rad], turning at ``vth`` [rad/s]."""
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=goal_yaw)
    lp.set_plan(plan)
    ok, cmd, _ = lp.compute_velocity(cm, (5.0, 5.0, yaw), (0.0, 0.0, vth), plan)
    assert ok
    return lp.is_goal_reached(), cmd


def test_ros_rule_reaches_inside_the_tolerance_whatever_the_turn():
    # 0.25 rad short and turning at 1 rad/s: ROS stops here and the robot coasts 0.5 rad on,
    # to 0.25 rad past the goal yaw
    assert _reached_while_turning(planner(), -0.25, 1.0)[0]


@pytest.mark.parametrize(("yaw", "vth", "reached", "turn"), [
    (-0.70, 1.0, False, False),  # 0.7 - (0.2 + 0.5) = 0.0: a zero command now leaves it on the goal yaw
    (-0.80, 1.0, False, False),  # 0.1 short once it stands: within half the tolerance, stop
    (-1.20, 1.0, False, True),   # 1.2 - 0.7 = 0.5 rad short: turn on
    (-0.25, 1.0, False, False),  # 0.45 rad past even if it stops now: stop, and turn back at rest
    (0.10, 1.0, False, False),   # 0.1 past and turning away from the goal: stop
    (0.10, -1.0, False, False),  # 0.1 past, turning back toward the goal: 0.6 past the other way: stop
    (-0.20, 0.05, True, False),  # at rest (below rot_stopped_velocity): ROS's rule, within 0.3 rad
    (0.20, 0.05, True, False),
    (-0.40, 0.05, False, True),
])
def test_coast_to_goal_yaw_judges_where_a_zero_command_leaves_the_robot(yaw, vth, reached, turn):
    lp = planner(coast_to_goal_yaw=True, command_lag=0.2, acc_lim_th=1.0)
    got, cmd = _reached_while_turning(lp, yaw, vth)
    assert got is reached
    assert (cmd[2] != 0.0) is turn


def test_coast_to_goal_yaw_counts_the_pose_age():
    # 1.0 rad short at 1 rad/s: 0.5 rad of braking and 0.2 rad of command lag leave it 0.3 rad short:
    # turn on; with the pose 0.2 s old as well, 0.1 rad short: stop
    lp = planner(coast_to_goal_yaw=True, command_lag=0.2, acc_lim_th=1.0)
    assert _reached_while_turning(lp, -1.0, 1.0)[1][2] > 0.0
    lp = planner(coast_to_goal_yaw=True, command_lag=0.2, acc_lim_th=1.0)
    lp.pose_age = 0.2
    assert _reached_while_turning(lp, -1.0, 1.0)[1][2] == 0.0


def _settle(coast, yaw0, w0):
    """Closed loop at 5 Hz from ``yaw0`` [rad] (goal yaw 0) turning at ``w0`` [rad/s]: a base that acts
    on a command a control period late and changes its turn rate by at most 1 rad/s^2
    (velocity_filter). Returns ((yaw, turn rate) when the goal was reached, the yaw it stands at)."""
    lp = planner(coast_to_goal_yaw=coast, command_lag=0.2, acc_lim_th=1.0)
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=0.0)
    lp.set_plan(plan)
    yaw, w, acting, pending, reached_at = yaw0, w0, w0, w0, None
    for _ in range(100):
        for _ in range(10):  # one control period (0.2 s) of the base, toward the command it acts on
            w += float(np.clip(acting - w, -0.02, 0.02))
            yaw += w * 0.02
        acting = pending  # the command of the last cycle reaches the base now
        if reached_at is None:
            ok, c, _ = lp.compute_velocity(cm, (5.0, 5.0, yaw), (0.0, 0.0, w), plan)
            assert ok
            pending = c[2]
            if lp.is_goal_reached():
                reached_at = (yaw, w)
        else:
            pending = 0.0
            if abs(w) < 1e-9 and acting == 0.0:
                break
    assert reached_at is not None
    return reached_at, yaw


@pytest.mark.parametrize(("yaw0", "w0"), [(-1.5, 1.4), (1.4, -1.3)])
def test_ros_rule_stands_beyond_the_yaw_tolerance_after_a_fast_turn(yaw0, w0):
    (_, w_at), yaw_end = _settle(False, yaw0, w0)
    assert abs(w_at) >= 0.9 and abs(yaw_end) > 0.3  # reached while turning fast; it coasts on past


@pytest.mark.parametrize(("yaw0", "w0"), [(-1.5, 1.4), (-1.2, 1.0), (-2.5, 1.5), (1.4, -1.3), (-0.6, 0.0)])
def test_coast_to_goal_yaw_settles_inside_the_tolerance(yaw0, w0):
    (yaw_at, w_at), yaw_end = _settle(True, yaw0, w0)
    assert abs(w_at) <= 0.1 and abs(yaw_at) <= 0.3 and abs(yaw_end) <= 0.3  # reached at rest, and stays


def test_outside_xy_tolerance_drives_on():
    cm = Costmap2D(100, 100, 0.1)
    lp = planner()
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=0.0)
    lp.set_plan(plan)
    ok, cmd, _ = lp.compute_velocity(cm, (4.7, 5.0, 0.0), (0.0, 0.0, 0.0), plan)  # 0.30 m > 0.25 m
    assert ok and cmd[0] > 0.0 and not lp.is_goal_reached()
    assert len(lp.local_plan) > 0


@pytest.mark.parametrize(("yaw", "goal_yaw", "sign"), [(0.0, 1.0, 1), (0.0, -1.0, -1), (-2.8, 2.8, -1),
                                                       (2.8, -2.8, 1), (0.0, 0.4, 1)])
def test_rotate_to_goal_direction_and_speed(yaw, goal_yaw, sign):
    cm = Costmap2D(100, 100, 0.1)
    lp = planner()
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=goal_yaw)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (5.0, 5.05, yaw), (0.0, 0.0, 0.0), plan)
    assert ok and cmd[0] == 0.0 and cmd[1] == 0.0
    assert math.copysign(1.0, cmd[2]) == sign
    # between min_in_place_vel_theta (1.0) and max_vel_theta (1.5); from rest at most
    # acc_lim_theta * sim_period = 0.6 rad/s reachable, but min_in_place_vel_theta wins (ROS)
    assert abs(cmd[2]) == pytest.approx(1.0)
    assert "rotating" in reason and not lp.is_goal_reached()
    assert len(lp.local_plan) == 0


def test_rotate_to_goal_speed_respects_acceleration_and_stopping_distance():
    cm = Costmap2D(100, 100, 0.1)
    lp = planner(min_in_place_rotational_vel=0.1, yaw_goal_tolerance=0.05)
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=2.0)
    lp.set_plan(plan)
    # still turning at 1.4 rad/s: first brake by acc_lim_theta * sim_period = 3.0 * 0.2 rad/s
    ok, cmd, reason = lp.compute_velocity(cm, (5.0, 5.0, 0.9), (0.0, 0.0, 1.4), plan)
    assert ok and "braking" in reason
    assert cmd[2] == pytest.approx(1.4 - 0.6)
    # stopped (0.05 rad/s <= 0.1): rotate; error 1.0 rad asks 1.0 rad/s, reachable only 0.05 + 0.6
    ok, cmd, reason = lp.compute_velocity(cm, (5.0, 5.0, 1.0), (0.0, 0.0, 0.05), plan)
    assert ok and "rotating" in reason
    assert cmd[2] == pytest.approx(0.65)
    # rotating (latched) at 1.4 rad/s with 0.1 rad to go: can only slow to 0.8 rad/s, but must be
    # able to stop in 0.1 rad: sqrt(2 * 3.0 * 0.1) rad/s
    ok, cmd, reason = lp.compute_velocity(cm, (5.0, 5.0, 1.9), (0.0, 0.0, 1.4), plan)
    assert ok and "rotating" in reason
    assert cmd[2] == pytest.approx(math.sqrt(0.6))


def test_braking_before_rotating_when_still_moving():
    cm = Costmap2D(100, 100, 0.1)
    lp = planner()
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=1.5)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.9, 5.0, 0.0), (0.3, 0.0, 0.0), plan)
    assert ok and "braking" in reason
    assert cmd == pytest.approx((0.3 - 0.5 * 0.2, 0.0, 0.0))  # acc_lim_x * sim_period


def test_xy_goal_tolerance_latch():
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=1.5)
    for latch, expect_rotation in ((True, True), (False, False)):
        lp = planner(latch_xy_goal_tolerance=latch)
        lp.set_plan(plan)
        ok, cmd, _ = lp.compute_velocity(cm, (4.9, 5.0, 0.0), (0.0, 0.0, 0.0), plan)
        assert ok and cmd[0] == 0.0 and cmd[2] > 0.0
        # drifted out of the xy tolerance (0.4 m from the goal)
        ok, cmd, reason = lp.compute_velocity(cm, (4.6, 5.0, 0.0), (0.0, 0.0, 0.0), plan)
        assert ok
        assert ("rotating" in reason) == expect_rotation
        if not expect_rotation:
            assert cmd[0] > 0.0
        # a plan to another goal clears the latch
        other = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=1.4)
        lp.set_plan(other)
        ok, cmd, reason = lp.compute_velocity(cm, (4.6, 5.0, 0.0), (0.0, 0.0, 0.0), other)
        assert "rotating" not in reason


def test_replanning_to_the_same_goal_keeps_the_rotation_to_the_goal_yaw():
    """move_base replans at planner_frequency: the new plan ends at the same goal, and the robot
    that was turning on the spot must go on turning, not brake and drive again."""
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=2.5)
    lp = planner(latch_xy_goal_tolerance=True)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.8, 5.0, 0.0), (0.0, 0.0, 0.0), plan)
    assert ok and "rotating" in reason
    # turning at 1.0 rad/s, 0.3 m from the goal (outside xy_goal_tolerance), a replan arrives
    replan = line_plan(4.7, 5.0, 5.0, 5.0, yaw_end=2.5)
    lp.set_plan(replan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.7, 5.0, 1.0), (0.0, 0.0, 1.0), replan)
    assert ok and "rotating" in reason and "braking" not in reason
    assert cmd[0] == 0.0 and cmd[2] >= 1.0


# --- plan window ---------------------------------------------------------------------------------

def test_prune_drops_poses_behind_until_one_within_a_metre():
    plan = line_plan(0.0, 5.0, 8.0, 5.0)  # poses every 0.05 m
    assert prune_count((3.0, 5.0), plan) == round((3.0 - 1.0) / 0.05) + 1  # first at x > 2.0
    assert prune_count((3.0, 9.0), plan) == len(plan)
    assert prune_count((0.0, 5.0), plan) == 0


def test_clip_keeps_the_poses_within_half_the_costmap():
    cm = Costmap2D(100, 60, 0.1)  # 10 m x 6 m: threshold 5 m
    plan = line_plan(-4.0, 3.0, 14.0, 3.0)
    window, first = clip_plan(cm, (5.0, 3.0), plan)
    assert window[0, 0] >= 0.0 - 1e-9 and window[0, 0] < 0.05 + 1e-9
    assert window[-1, 0] <= 10.0 + 1e-9 and window[-1, 0] > 9.95 - 1e-9
    assert first == int(np.argmax(np.abs(plan[:, 0] - 5.0) <= 5.0))


def test_compute_velocity_prunes_the_stored_plan():
    cm = Costmap2D(100, 100, 0.1)
    lp = planner()
    plan = line_plan(1.0, 5.0, 8.0, 5.0)
    lp.set_plan(plan)
    ok, _, _ = lp.compute_velocity(cm, (3.0, 5.0, 0.0), (0.0, 0.0, 0.0), plan)
    assert ok
    assert len(lp.global_plan) == len(plan) - prune_count((3.0, 5.0), plan)
    assert np.hypot(*(lp.transformed_plan[0, :2] - (3.0, 5.0))) < 1.0


def test_empty_window_and_blocked_robot_fail_with_a_reason():
    cm = Costmap2D(100, 100, 0.1)
    lp = planner()
    far = line_plan(30.0, 30.0, 40.0, 30.0)
    lp.set_plan(far)
    ok, cmd, reason = lp.compute_velocity(cm, (5.0, 5.0, 0.0), (0.0, 0.0, 0.0), far)
    assert not ok and cmd == (0.0, 0.0, 0.0) and "plan" in reason
    cm.costs[:, 70] = LETHAL_OBSTACLE  # the goal is cut off: no trajectory has a route to it
    plan = line_plan(5.0, 5.0, 8.0, 5.0)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (5.0, 5.0, 0.0), (0.0, 0.0, 0.0), plan)
    assert not ok and cmd == (0.0, 0.0, 0.0) and reason.startswith(NO_VALID_TRAJECTORY + ": ")
    # why, for the log and the abort text: every sample ends where the plan's distances do not reach
    samples = lp.planner.failures["samples"]
    assert samples > 0 and lp.planner.failures["unreachable"] == samples
    assert f"0 of {samples} samples hit an obstacle or unknown cell, {samples} leave the plan's reach" in reason
    assert reason.endswith("the footprint is clear where it stands")
    counts = failure_counts([-1.0, -2.0, -3.0, -1.0], -1.0, 12.0)  # the padded outline touches, the body does not
    assert failure_text(counts) == ("2 of 4 samples hit an obstacle or unknown cell, 1 leave the plan's reach, 1 come "
                                    "too near a person; the padded footprint touches an obstacle or unknown cell "
                                    "where it stands")
    assert failure_text({**counts, "body_here": -1.0}).endswith("the body touches an obstacle or unknown cell where it "
                                                                "stands")


# --- closed loop -----------------------------------------------------------------------------------

def _drive(lp, cm, start, plan, seconds, acc=(0.5, 0.5, 3.0)):
    """Kinematic loop at controller_frequency: the base follows each command within its
    acceleration limits [m/s^2, m/s^2, rad/s^2]; returns the poses visited."""
    dt = lp.params.sim_period
    x, y, yaw = start
    v = np.zeros(3)
    poses = [(x, y, yaw)]
    lp.set_plan(plan)
    for _ in range(int(seconds / dt)):
        ok, cmd, reason = lp.compute_velocity(cm, (x, y, yaw), tuple(v), plan)
        assert ok, reason
        if lp.is_goal_reached():
            break
        (x, y, yaw), v = _base_step((x, y, yaw), v, cmd, acc, dt)
        poses.append((x, y, yaw))
    return np.array(poses)


def _base_step(pose, v, cmd, acc, dt):
    """The base a control period on: its velocity ``v`` toward ``cmd`` within the acceleration limits
    ``acc`` (each of vx, vy, vth), then the pose moved by it: (pose, v)."""
    x, y, yaw = pose
    v = v + np.clip(np.asarray(cmd) - v, -np.asarray(acc) * dt, np.asarray(acc) * dt)
    c, s = math.cos(yaw), math.sin(yaw)
    return (x + (v[0] * c - v[1] * s) * dt, y + (v[0] * s + v[1] * c) * dt, angles.wrap(yaw + v[2] * dt)), v


def test_corridor_drive_reaches_a_goal_three_metres_away():
    res = 0.1
    lethal = np.zeros((100, 100), bool)
    lethal[40, :] = True  # walls: y in [4.0, 4.1) and [6.0, 6.1) [m]
    lethal[60, :] = True
    cm = Costmap2D(100, 100, res)
    cm.costs[:] = inflated(lethal, res)
    lp = planner()
    goal_yaw = 1.2
    plan = line_plan(2.0, 5.0, 5.0, 5.0, yaw_end=goal_yaw)
    poses = _drive(lp, cm, (2.0, 5.0, 0.0), plan, seconds=30.0)
    assert lp.is_goal_reached()
    x, y, yaw = poses[-1]
    assert math.hypot(x - 5.0, y - 5.0) <= 0.25 + 0.05
    assert abs(angles.diff(yaw, goal_yaw)) <= 0.3
    # never closer to a wall than the footprint's circumscribed radius allows
    assert np.all(poses[:, 1] - CIRCUMSCRIBED > 4.1) and np.all(poses[:, 1] + CIRCUMSCRIBED < 6.0)
    assert np.all(np.diff(poses[:, 0]) > -0.05)  # no backing up in an open corridor


def test_goal_near_a_wall_drives_on_when_the_turn_would_collide():
    """At the edge of xy_goal_tolerance next to a wall a turn on the spot would sweep the footprint's
    nose (0.25 m) into it: the robot drives on toward the goal position and turns there."""
    res = 0.05
    lethal = np.zeros((100, 100), bool)
    lethal[:, 60] = True  # a wall at x = 3.0 m
    cm = Costmap2D(100, 100, res)
    cm.costs[:] = inflated(lethal, res)
    plan = line_plan(1.0, 2.5, 2.6, 2.5, yaw_end=math.pi / 2)  # goal 0.4 m from the wall, facing it
    lp = planner(latch_xy_goal_tolerance=True)
    lp.set_plan(plan)
    # 0.19 m past the goal, the back to the wall (0.04 m from it): the rear corners would sweep
    # into it during a turn on the spot
    pose = (2.79, 2.5, math.pi)
    ok, cmd, reason = lp.compute_velocity(cm, pose, (0.0, 0.0, 0.0), plan)
    assert ok, reason
    assert not lp._rotate_to_goal(cm, *pose, 0.0, 0.0, 0.0, math.pi / 2)[0]  # ROS would fail here
    assert "rotating" not in reason and cmd != (0.0, 0.0, 0.0)
    # closed loop: it gets to the goal position and turns there
    poses = _drive(lp, cm, pose, plan, seconds=30.0, acc=(1.0, 1.0, 1.0))
    assert lp.is_goal_reached()
    assert math.hypot(poses[-1, 0] - 2.6, poses[-1, 1] - 2.5) <= 0.25
    # the footprint never reached the wall
    assert max(transform_footprint(FOOTPRINT, *p)[:, 0].max() for p in poses) < 3.0


# --- Florence: final approach and turning while braking -------------------------------------------

FLORENCE = {"latch_xy_goal_tolerance": True, "acc_lim_th": 1.0, "final_approach_dist": 0.8,
            "rotate_while_braking": True}


def test_final_approach_keeps_the_speed_it_can_brake_from_at_the_goal():
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(2.0, 5.0, 5.0, 5.0, yaw_end=0.0)
    lp = planner(**FLORENCE)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.4, 5.0, 0.0), (0.5, 0.0, 0.0), plan)  # 0.6 m to go
    assert ok and reason == "final approach"
    assert cmd == pytest.approx((0.5, 0.0, 0.0), abs=1e-9)  # sqrt(2 * 0.5 * 0.6) > max_vel_x
    assert len(lp.local_plan) > 0
    # braking at 0.3 m/s^2 from 0.3 m to go: sqrt(2 * 0.3 * 0.3) = 0.42 m/s, within a step of 0.45 m/s
    slow = planner(**{**FLORENCE, "acc_lim_x": 0.3})
    slow.set_plan(plan)
    ok, cmd, reason = slow.compute_velocity(cm, (4.7, 5.0, 0.0), (0.45, 0.0, 0.0), plan)
    assert reason == "final approach"
    assert cmd[0] == pytest.approx(math.sqrt(2 * 0.3 * 0.3), abs=1e-9)
    # ROS (off): the rollouts' goal distance at the end of sim_time asks for a slower speed
    ros = planner(**{**FLORENCE, "final_approach_dist": 0.0})
    ros.set_plan(plan)
    ok, cmd, reason = ros.compute_velocity(cm, (4.4, 5.0, 0.0), (0.5, 0.0, 0.0), plan)
    assert ok and reason == "" and cmd[0] < 0.5


def test_final_approach_steers_onto_the_plan():
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(2.0, 5.0, 5.0, 5.0, yaw_end=0.0)
    lp = planner(**FLORENCE)
    lp.set_plan(plan)
    _, cmd, reason = lp.compute_velocity(cm, (4.4, 5.1, 0.0), (0.5, 0.0, 0.0), plan)  # 0.1 m left of it
    assert reason == "final approach" and cmd[2] < 0.0  # turns right, back toward it


@pytest.mark.parametrize("case", ["farther", "behind", "corner", "obstacle"])
def test_final_approach_leaves_the_cycle_to_the_rollouts(case):
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(2.0, 5.0, 5.0, 5.0, yaw_end=0.0)
    pose = (4.4, 5.0, 0.0)
    if case == "farther":
        pose = (4.1, 5.0, 0.0)  # 0.9 m > final_approach_dist
    elif case == "behind":
        pose = (4.4, 5.0, 2.0)  # the goal 2 rad off the heading
    elif case == "corner":  # the plan turns a corner: 0.7 m apart, 1.2 m along the plan
        plan = np.vstack([line_plan(4.4, 5.0, 4.4, 5.6)[:-1], line_plan(4.4, 5.6, 5.0, 5.6, yaw_end=0.0)])
        pose = (4.45, 5.0, 0.8)
    else:  # something 0.4 m ahead: braking from 0.5 m/s (0.25 m plus a control period) would hit it
        cm.costs[45:55, 49] = LETHAL_OBSTACLE
    lp = planner(**FLORENCE)
    lp.set_plan(plan)
    _, _, reason = lp.compute_velocity(cm, pose, (0.5, 0.0, 0.0), plan)
    assert reason != "final approach"


def test_rotate_while_braking():
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=1.5)
    lp = planner(**FLORENCE)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.9, 5.0, 0.0), (0.3, 0.0, 0.0), plan)
    assert ok and reason == "braking and turning to the goal yaw"
    assert cmd == pytest.approx((0.3 - 0.5 * 0.2, 0.0, 1.0 * 0.2))  # acc_lim_x, acc_lim_th per period
    # the odometry lags a cycle behind (still 0.3 m/s): the ramps go on from the last command
    ok, cmd, reason = lp.compute_velocity(cm, (4.95, 5.0, 0.0), (0.3, 0.0, 0.0), plan)
    assert cmd == pytest.approx((0.1, 0.0, 0.4))
    # translation stopped: the turn on the spot takes over
    ok, cmd, reason = lp.compute_velocity(cm, (5.0, 5.0, 0.2), (0.05, 0.0, 0.4), plan)
    assert reason == "rotating to the goal yaw" and cmd[0] == 0.0 and cmd[2] > 0.0
    # ROS (off): brake first
    ros = planner(**{**FLORENCE, "rotate_while_braking": False})
    ros.set_plan(plan)
    ok, cmd, reason = ros.compute_velocity(cm, (4.9, 5.0, 0.0), (0.3, 0.0, 0.0), plan)
    assert reason == "braking before rotating to the goal yaw" and cmd[2] == 0.0


def test_rotate_while_braking_brakes_straight_when_the_arc_would_collide():
    """A post 0.28 m ahead-left of the robot: the turn on the spot here is free (the footprint
    reaches 0.262 m), but not at the end of the braking arc 0.09 m on, so the robot brakes straight
    as ROS does."""
    res = 0.05
    cm = Costmap2D(100, 100, res)
    cm.costs[54, 44] = LETHAL_OBSTACLE  # the cell [2.20, 2.25] x [2.70, 2.75] m
    plan = line_plan(1.0, 2.5, 2.1, 2.5, yaw_end=math.pi / 2)
    lp = planner(**FLORENCE)
    lp.set_plan(plan)
    assert lp._turn_is_free(cm, 2.0, 2.5, 0.0, math.pi / 2)
    assert not lp._turn_is_free(cm, 2.09, 2.5, 0.0, math.pi / 2)
    ok, cmd, reason = lp.compute_velocity(cm, (2.0, 2.5, 0.0), (0.4, 0.0, 0.0), plan)
    assert ok and reason == "braking before rotating to the goal yaw"
    assert cmd == pytest.approx((0.3, 0.0, 0.0))


def _corridor_approach_seconds(variants, goal_yaw, xy_slack):
    """Drive a 3 m corridor leg (walls 2 m apart) to a goal at ``goal_yaw`` [rad] with each of
    ``variants`` (name: parameter overrides); check that each ends within the goal tolerances (the
    xy one plus ``xy_slack`` [m]) without leaving the corridor; return the seconds per name."""
    res = 0.1
    lethal = np.zeros((100, 100), bool)
    lethal[40, :] = True
    lethal[60, :] = True
    cm = Costmap2D(100, 100, res)
    cm.costs[:] = inflated(lethal, res)
    plan = line_plan(2.0, 5.0, 5.0, 5.0, yaw_end=goal_yaw)
    seconds = {}
    for name, over in variants.items():
        lp = planner(**over)
        poses = _drive(lp, cm, (2.0, 5.0, 0.0), plan, seconds=30.0, acc=(1.0, 1.0, 1.0))
        assert lp.is_goal_reached(), name
        x, y, yaw = poses[-1]
        assert math.hypot(x - 5.0, y - 5.0) <= 0.25 + xy_slack
        assert abs(angles.diff(yaw, goal_yaw)) <= 0.3
        assert np.all(poses[:, 1] - CIRCUMSCRIBED > 4.1) and np.all(poses[:, 1] + CIRCUMSCRIBED < 6.0)
        seconds[name] = (len(poses) - 1) * lp.params.sim_period
    print(seconds)
    return seconds


def test_florence_approach_is_faster_and_ends_within_the_tolerances():
    seconds = _corridor_approach_seconds(
        {"ros": {**FLORENCE, "final_approach_dist": 0.0, "rotate_while_braking": False}, "florence": FLORENCE},
        goal_yaw=1.2, xy_slack=0.05)
    # measured: 8.2 s with ROS's approach, 7.2 s with the final approach and the turn while braking
    assert seconds["florence"] <= seconds["ros"] - 0.6


# --- Florence: turning to the goal yaw before the xy tolerance -------------------------------------

EARLY = {**FLORENCE, "turn_before_tolerance": True}


def test_giving_way_ends_at_the_place_without_the_turn_to_the_goal_yaw():
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(3.0, 5.0, 5.0, 5.0, yaw_end=1.5)
    lp = planner(**EARLY)
    lp.set_plan(plan, giving_way=True)
    ok, cmd, reason = lp.compute_velocity(cm, (4.9, 5.0, 0.0), (0.3, 0.0, 0.0), plan)
    assert ok and cmd == (0.0, 0.0, 0.0) and lp.is_goal_reached() and reason.startswith("goal reached")
    # outside xy_goal_tolerance it drives on, and it does not start the turn before the tolerance
    lp.set_plan(plan, giving_way=True)
    ok, cmd, reason = lp.compute_velocity(cm, (4.6, 5.0, 0.0), (0.5, 0.0, 0.0), plan)
    assert ok and cmd[0] > 0.0 and reason != "braking and turning to the goal yaw" and not lp.is_goal_reached()
    # the goal itself: the turn to its yaw, begun before the tolerance
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.6, 5.0, 0.0), (0.5, 0.0, 0.0), plan)
    assert reason == "braking and turning to the goal yaw" and not lp.is_goal_reached()
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.9, 5.0, 0.0), (0.3, 0.0, 0.0), plan)
    assert reason == "braking and turning to the goal yaw" and not lp.is_goal_reached()


def test_goal_turn_time_in_place_matches_the_braking_profile():
    """At rest on the goal position, a quarter turn with acc_lim_th 1 rad/s^2 and the braking
    profile sqrt(2 a |error|): speed up until w = sqrt(2 (pi/2 - w^2 / 2)), i.e. for sqrt(pi/2) s,
    then slow down along the profile until 0.3 rad remain, at w = sqrt(0.6)."""
    p = planner(**EARLY).params
    (t,), (end,), _, _ = goal_turn_times(p, (5.0, 5.0, 0.0), 0.0, 0.0, (5.0, 5.0, math.pi / 2), 0.0, 0.5,
                                         step=0.001)
    assert t == pytest.approx(2 * math.sqrt(math.pi / 2) - math.sqrt(0.6), abs=0.01)
    assert end == pytest.approx(0.0)
    # already within both tolerances
    times, ends, poses, stops = goal_turn_times(p, (5.1, 5.0, 0.2), 0.0, 0.0, (5.0, 5.0, 0.0), 0.0, 0.5)
    assert times[0] == 0.0 and ends[0] == pytest.approx(0.1) and len(poses) == 0 and stops[0] == 0


def test_goal_turn_time_straight_in_and_the_stop_after_it():
    """Heading for the goal yaw already: reached on entering the tolerance; the stop lies the
    braking distance v^2 / (2 acc_lim_x) beyond the point where the braking starts."""
    p = planner(**EARLY).params
    # options: drive on for 10 s or brake at once, at 0.5 and at 0.15 m/s^2
    times, ends, poses, stops = goal_turn_times(p, (4.0, 5.0, 0.0), 0.5, 0.0, (5.0, 5.0, 0.0),
                                                [10.0, 0.0, 0.0], [0.5, 0.5, 0.15], step=0.01)
    assert times[0] == pytest.approx((1.0 - 0.25) / 0.5, abs=0.02)
    assert ends[0] == pytest.approx(0.25 - 0.25, abs=0.02)  # braking 0.25 m from the tolerance's edge
    assert math.isinf(times[1]) and ends[1] == pytest.approx(0.75, abs=0.02)  # braking at once stops short
    # gently: within the tolerance when 0.5 t - 0.075 t^2 = 0.75; it stops 0.5^2 / 0.3 m on
    assert times[2] == pytest.approx((0.5 - math.sqrt(0.25 - 0.225)) / 0.15, abs=0.03)
    assert ends[2] == pytest.approx(1.0 - 0.25 / 0.3, abs=0.02)
    # the poses run along the x axis until each option stopped or reached the goal
    assert poses.shape[1:] == (3, 3) and len(poses) >= stops.max()
    assert stops[0] == pytest.approx(150, abs=1) and stops[1] == pytest.approx(100, abs=1)
    assert poses[stops[1] - 1, 1, 0] == pytest.approx(4.25, abs=0.01)
    assert all(np.all(poses[:k, i, 1] == 5.0) and np.all(np.isnan(poses[k:, i])) for i, k in enumerate(stops))


def test_turn_before_tolerance_starts_when_it_ends_inside_and_sooner():
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(2.0, 5.0, 5.0, 5.0, yaw_end=math.pi)
    lp = planner(**EARLY)
    lp.set_plan(plan)
    # 0.42 m to go at 0.5 m/s: braking now, at any of the rates, reaches the goal in 2.8 s, sooner
    # than after driving on into the tolerance. Braking at acc_lim_x would stop 0.19 m from the goal
    # (simulated, the arc included), at 0.65 acc_lim_x 0.09 m: the nearest stop of the equally
    # soon options wins. The goal is a half turn away: florence_common.angles wraps it to -pi, so the
    # turn is clockwise (the planner's own atan2 wrap gave +pi before the shared angle module)
    ok, cmd, reason = lp.compute_velocity(cm, (4.58, 5.0, 0.0), (0.5, 0.0, 0.0), plan)
    assert ok and reason == "braking and turning to the goal yaw"
    assert cmd == pytest.approx((0.5 - 0.65 * 0.5 * 0.2, 0.0, -1.0 * 0.2))
    assert math.hypot(lp.local_plan[-1, 0] - 5.0, lp.local_plan[-1, 1] - 5.0) < 0.1
    # 0.5 m to go: braking at acc_lim_x would stop 0.26 m from the goal (simulated, the arc included),
    # at 0.65 acc_lim_x 0.16 m; the gentler braking starts the turn a control period sooner
    lp = planner(**EARLY)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (4.5, 5.0, 0.0), (0.5, 0.0, 0.0), plan)
    assert ok and reason == "braking and turning to the goal yaw"
    assert 0.5 - 0.5 * 0.2 < cmd[0] < 0.5 and cmd[2] < 0.0  # clockwise: the half turn, see above
    # off (Florence's final approach only): drives on
    late = planner(**FLORENCE)
    late.set_plan(plan)
    assert late.compute_velocity(cm, (4.58, 5.0, 0.0), (0.5, 0.0, 0.0), plan)[2] == "final approach"


@pytest.mark.parametrize(("pose", "goal_yaw"), [
    ((4.2, 5.0, 0.0), math.pi),  # 0.8 m to go: even the gentlest braking stops 0.3 m short
    ((4.58, 5.0, 0.0), 0.1),  # the goal yaw is already within yaw_goal_tolerance
    ((4.58, 5.0, 0.0), 0.32),  # 0.02 rad to turn: driving on into the tolerance is sooner than braking
])
def test_turn_before_tolerance_drives_on(pose, goal_yaw):
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(2.0, 5.0, 5.0, 5.0, yaw_end=goal_yaw)
    lp = planner(**EARLY)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, pose, (0.5, 0.0, 0.0), plan)
    assert ok and reason == "final approach" and cmd[0] == pytest.approx(0.5)


def test_turn_before_tolerance_is_faster_and_ends_within_the_tolerances():
    seconds = _corridor_approach_seconds({"late": FLORENCE, "early": EARLY}, goal_yaw=3.0, xy_slack=0.0)
    # measured: 8.6 s turning once within the tolerance, 8.2 s turning before it
    assert seconds["early"] <= seconds["late"] - 0.2


def test_a_turn_to_the_goal_yaw_that_becomes_blocked_drives_on_to_the_goal_position():
    """A turn on the spot had begun 0.19 m from the goal position when the costmap changed (here a wall 0.04 m
    behind the robot appears): the rest of the turn would sweep the rear corners into it. The robot drives on
    toward the goal position and turns there; it used to go on failing 'the rotation collides' to an abort."""
    res = 0.05
    cm = Costmap2D(100, 100, res)
    plan = line_plan(1.0, 2.5, 2.6, 2.5, yaw_end=math.pi / 2)
    lp = planner(latch_xy_goal_tolerance=True)
    lp.set_plan(plan)
    pose = (2.79, 2.5, math.pi)
    ok, _, reason = lp.compute_velocity(cm, pose, (0.0, 0.0, 0.0), plan)  # nothing near yet: it turns
    assert ok and reason == "rotating to the goal yaw" and lp._rotating_to_goal
    lethal = np.zeros((100, 100), bool)
    lethal[:, 60] = True  # a wall at x = 3.0 m
    cm.costs[:] = inflated(lethal, res)
    pose = (2.79, 2.5, math.pi - 0.1)
    ok, _, reason = lp.compute_velocity(cm, pose, (0.0, 0.0, 0.3), plan)
    assert ok, reason
    assert "rotating" not in reason
    poses = _drive(lp, cm, pose, plan, seconds=30.0, acc=(1.0, 1.0, 1.0))
    assert lp.is_goal_reached()
    assert math.hypot(poses[-1, 0] - 2.6, poses[-1, 1] - 2.5) <= 0.25
    assert max(transform_footprint(FOOTPRINT, *p)[:, 0].max() for p in poses) < 3.0


def test_a_turn_whose_braking_overshoot_would_collide_drives_on_to_the_goal_position():
    """0.14 m from the goal position, the turn on the spot to the goal yaw is free, but braking from the
    in-place speed (1 rad/s at 1 rad/s^2) would carry the nose on toward the wall 0.26 m away: the robot drives
    on toward the goal position and turns there, instead of failing 'the rotation collides' to an abort."""
    res = 0.05
    lethal = np.zeros((100, 100), bool)
    lethal[:, 60] = True  # a wall at x = 3.0 m
    cm = Costmap2D(100, 100, res)
    cm.costs[:] = inflated(lethal, res)
    plan = line_plan(1.0, 2.5, 2.6, 2.5, yaw_end=-0.96)
    lp = planner(latch_xy_goal_tolerance=True, acc_lim_th=1.0)
    lp.set_plan(plan)
    pose = (2.74, 2.5, math.pi)
    assert lp._turn_is_free(cm, *pose, -0.96) and not lp._rotate_to_goal(cm, *pose, 0.0, 0.0, 0.0, -0.96)[0]
    ok, _, reason = lp.compute_velocity(cm, pose, (0.0, 0.0, 0.0), plan)
    assert ok, reason
    poses = _drive(lp, cm, pose, plan, seconds=30.0, acc=(1.0, 1.0, 1.0))
    assert lp.is_goal_reached()
    assert math.hypot(poses[-1, 0] - 2.6, poses[-1, 1] - 2.5) <= 0.25
    assert max(transform_footprint(FOOTPRINT, *p)[:, 0].max() for p in poses) < 3.0


# --- turn_to_plan_angle ------------------------------------------------------------------------

TURNING_TO_PLAN = "turning on the spot toward the plan"


def _doorway():
    """A 4 x 4 m costmap from (0.5, 4.0) [m] with a 0.1 m wall along y = 5.5 m and a 0.9 m door in it
    (x 2.0..2.9), as between the apartment's corridor and living room; and a plan from the robot's
    place in the door, 0.1 m on the living room's side, north into the corridor, then west."""
    res = 0.05
    lethal = np.zeros((80, 80), bool)
    lethal[29:31, :] = True  # y 5.45..5.55
    lethal[29:31, 30:48] = False  # x 2.0..2.9
    cm = Costmap2D(80, 80, res, 0.5, 4.0)
    cm.costs[:] = inflated(lethal, res)
    plan = np.vstack([line_plan(2.46, 5.40, 2.45, 6.15), line_plan(2.45, 6.15, 0.6, 6.15, yaw_end=math.pi)[1:]])
    return cm, plan


def _leave_the_doorway(lp, cm, plan, pose, seconds=12.0):
    """Kinematic loop (as _drive, 1 rad/s^2 turns as the launch's acc_lim_th) until the robot's centre is
    0.5 m into the corridor (y > 6.0 m): (time [s] or None, poses, commands, reasons)."""
    dt = lp.params.sim_period
    x, y, yaw = pose
    v = np.zeros(3)
    poses, cmds, reasons = [pose], [], []
    lp.set_plan(plan)
    for k in range(int(seconds / dt)):
        _, cmd, reason = lp.compute_velocity(cm, (x, y, yaw), tuple(v), plan)
        cmds.append(cmd)
        reasons.append(reason)
        (x, y, yaw), v = _base_step((x, y, yaw), v, cmd, (0.5, 0.5, 1.0), dt)
        poses.append((x, y, yaw))
        if y > 6.0:
            return (k + 1) * dt, np.array(poses), np.array(cmds), reasons
    return None, np.array(poses), np.array(cmds), reasons


def test_facing_away_from_the_plan_in_a_doorway_turns_on_the_spot_one_way_then_drives_out():
    """move_base gave way into the living room's door, the robot's back to the corridor; when the way was
    free its plan led north, behind it. The rollouts arced to and fro (their oscillation flags reset by
    each replan) while move_base's commands turned it on the spot (the collision monitor's state,
    "turning in place", is what it says of a command with no linear part): in florence_sim the robot
    stayed in the door until the recoveries turned it. With turn_to_plan_angle it turns on the spot, one
    way, without moving off its place, then drives out."""
    cm, plan = _doorway()
    start = (2.46, 5.40, math.radians(-100.0))
    t_on, poses, cmds, reasons = _leave_the_doorway(planner(acc_lim_th=1.0, turn_to_plan_angle=1.5), cm, plan, start)
    t_off, _, _, _ = _leave_the_doorway(planner(acc_lim_th=1.0), cm, plan, start)
    assert t_on is not None and t_on <= 5.0, t_on
    assert t_off is None or t_on < t_off, (t_on, t_off)
    turning = np.array([r == TURNING_TO_PLAN for r in reasons])
    assert turning[0] and turning.sum() >= 5
    assert np.all(cmds[turning, 0] == 0.0)  # at rest: no translation while turning
    assert len(set(np.sign(cmds[turning, 2]))) == 1  # one way round
    assert np.hypot(*(poses[: turning.sum() + 1, :2] - poses[0, :2]).T).max() < 0.01
    # handed to the rollouts within a third of the angle of the plan's heading (north)
    first_after = int(np.argmin(turning))
    assert abs(angles.diff(math.pi / 2, poses[first_after, 2])) <= 0.5 + 0.25
    assert all(poses_are_free(cm, poses, FOOTPRINT) for _ in [0])


def test_turn_to_plan_takes_the_longer_way_when_the_shorter_collides_and_keeps_it():
    """The plan leads 150 degrees to the left; something stands 0.26 m to the left, where the front
    corner would sweep it turning left: the robot turns 210 degrees right. It keeps that way when a
    replan to the same goal comes after the thing is gone and the left turn has become the shorter
    and free one; a plan to a new goal starts afresh."""
    res = 0.005
    cm = Costmap2D(400, 400, res)
    for b in np.radians(np.arange(80.0, 101.0)):
        cm.costs[int((1.0 + 0.2575 * math.sin(b)) / res), int((1.0 + 0.2575 * math.cos(b)) / res)] = LETHAL_OBSTACLE
    heading = math.radians(150.0)
    plan = line_plan(1.0, 1.0, 1.0 + 0.8 * math.cos(heading), 1.0 + 0.8 * math.sin(heading))
    lp = planner(acc_lim_th=1.0, turn_to_plan_angle=1.5)
    lp.set_plan(plan)
    assert not lp._sweep_is_free(cm, 1.0, 1.0, 0.0, heading)
    ok, cmd, reason = lp.compute_velocity(cm, (1.0, 1.0, 0.0), (0.0, 0.0, 0.0), plan)
    assert ok and reason == TURNING_TO_PLAN and cmd[0] == 0.0 and cmd[2] < 0.0
    # 20 degrees round, the thing gone: left would be 170 degrees, right 190
    cm.costs[:] = 0
    pose, turning = (1.0, 1.0, math.radians(-20.0)), (0.0, 0.0, -1.0)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, pose, turning, plan)
    assert ok and reason == TURNING_TO_PLAN and cmd[2] < 0.0
    lp.set_plan(plan[:-1])
    ok, cmd, reason = lp.compute_velocity(cm, pose, turning, plan[:-1])
    assert ok and reason == TURNING_TO_PLAN and cmd[2] > 0.0


def _via(heading, goal=(3.0, 3.0)):
    """A plan from (2, 2) 0.8 m toward ``heading`` [rad], then on to ``goal`` (yaw 0 there)."""
    mx, my = 2.0 + 0.8 * math.cos(heading), 2.0 + 0.8 * math.sin(heading)
    return np.vstack([line_plan(2.0, 2.0, mx, my), line_plan(mx, my, *goal, yaw_end=0.0)[1:]])


def test_turn_to_plan_turns_back_when_a_replan_swings_the_plan_round_behind_it():
    """A replan to the same goal that swings the plan round behind a turn under way (a person seen,
    another way round) leaves that turn's way more than a half turn and 0.5 rad to go: the other way
    is taken. In bench/nav.py seed 1 a turn of 2.45 rad so went on round to 5.85 rad (5.6 s). Less
    than that left: the turn keeps its way."""
    cm = Costmap2D(100, 100, 0.05)
    lp = planner(acc_lim_th=1.0, turn_to_plan_angle=1.5)
    plan = _via(math.radians(100.0))
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (2.0, 2.0, 0.0), (0.0, 0.0, 0.0), plan)
    assert ok and reason == TURNING_TO_PLAN and cmd[2] > 0.0
    turned = (2.0, 2.0, math.radians(30.0))
    behind = _via(math.radians(-70.0))  # 100 degrees right of the robot now: 260 degrees on the left
    lp.set_plan(behind)
    ok, cmd, reason = lp.compute_velocity(cm, turned, (0.0, 0.0, 0.8), behind)
    assert ok and reason == TURNING_TO_PLAN and cmd[2] < 0.0
    lp = planner(acc_lim_th=1.0, turn_to_plan_angle=1.5)
    lp.set_plan(plan)
    lp.compute_velocity(cm, (2.0, 2.0, 0.0), (0.0, 0.0, 0.0), plan)
    near_behind = _via(math.radians(-130.0))  # 160 degrees right: 200 degrees on the left, kept
    lp.set_plan(near_behind)
    ok, cmd, reason = lp.compute_velocity(cm, turned, (0.0, 0.0, 0.8), near_behind)
    assert ok and reason == TURNING_TO_PLAN and cmd[2] > 0.0


def test_turn_to_plan_turns_once_per_place():
    """Once a turn toward the plan has ended, the next waits until the robot has moved 0.25 m: where
    the rollouts steer off the plan's next poses (a corner cut), the two turned the robot to and fro."""
    cm = Costmap2D(100, 100, 0.05)
    plan = line_plan(2.5, 2.5, 2.5, 4.0)  # north
    lp = planner(acc_lim_th=1.0, turn_to_plan_angle=1.5)
    lp.set_plan(plan)
    ok, cmd, reason = lp.compute_velocity(cm, (2.5, 2.5, math.pi), (0.0, 0.0, 0.0), plan)
    assert ok and reason == TURNING_TO_PLAN and cmd[2] < 0.0
    ok, cmd, reason = lp.compute_velocity(cm, (2.5, 2.5, math.pi / 2 + 0.3), (0.0, 0.0, -1.0), plan)
    assert ok and reason != TURNING_TO_PLAN and cmd[0] > 0.0  # within a third of the angle: it drives
    _, _, reason = lp.compute_velocity(cm, (2.5, 2.6, -0.2), (0.0, 0.0, 0.0), plan)
    assert reason != TURNING_TO_PLAN  # 0.1 m on: no second turn
    ok, cmd, reason = lp.compute_velocity(cm, (2.5, 2.8, -0.2), (0.0, 0.0, 0.0), plan)
    assert ok and reason == TURNING_TO_PLAN and cmd[2] > 0.0  # 0.3 m on


def test_a_turn_on_the_spot_beside_a_wall_keeps_the_body_clear_not_the_padded_footprint():
    """The launch pads the footprint by 0.06 m: its square back corners reach 0.31 m from the centre.
    A robot 0.30 m from a wall, its plan behind it, found no turn on the spot free, and the rollouts
    rocked it to and fro at 0.1 m/s (bench/nav.py seed 1: 12 legs ABORTED, oscillating). The round
    robot's turn sweeps nothing new: the body (padded 0.01 m, corners at 0.24 m) is what a turn keeps
    clear. The same turn with the padded footprint as the body is refused, as before."""
    res = 0.05
    lethal = np.zeros((60, 60), bool)
    lethal[:, 19:21] = True  # a wall x 0.95..1.05 m (its face 0.275 m from the robot's centre cell's)
    cm = Costmap2D(60, 60, res)
    cm.costs[:] = inflated(lethal, res)
    padded = pad_footprint(parse_footprint(_COMMON["footprint"]), 0.06)
    start = (1.325, 1.5, -math.pi / 2)  # facing south along the wall, 0.3 m from its centre line
    plan = line_plan(1.325, 1.5, 1.325, 2.8)  # north
    assert not poses_are_free(cm, [(1.325, 1.5, -math.pi / 2 + a) for a in np.linspace(0, math.pi, 37)], padded)

    def run(body):
        lp = LocalPlanner(PlannerParams.from_dict({**SEED, "acc_lim_th": 1.0, "turn_to_plan_angle": 1.5}), padded,
                          INSCRIBED, CIRCUMSCRIBED, body=body)
        lp.set_plan(plan)
        pose, v, reasons = start, np.zeros(3), []
        for _ in range(int(6.0 / lp.params.sim_period)):
            _, cmd, reason = lp.compute_velocity(cm, pose, tuple(v), plan)
            reasons.append(reason)
            pose, v = _base_step(pose, v, cmd, (0.5, 0.5, 1.0), lp.params.sim_period)
        return pose, reasons

    pose, reasons = run(FOOTPRINT)
    assert reasons[0] == TURNING_TO_PLAN
    assert pose[1] > 1.8, f"not on its way north: {pose}"
    assert poses_are_free(cm, [pose], FOOTPRINT)
    _, reasons = run(None)
    assert TURNING_TO_PLAN not in reasons


@pytest.mark.parametrize("heading_deg", [0.0, 60.0, -80.0])
def test_turn_to_plan_leaves_a_plan_ahead_to_the_rollouts(heading_deg):
    cm = Costmap2D(100, 100, 0.05)
    h = math.radians(heading_deg)
    plan = line_plan(2.5, 2.5, 2.5 + 1.5 * math.cos(h), 2.5 + 1.5 * math.sin(h))
    lp = planner(acc_lim_th=1.0, turn_to_plan_angle=1.5)
    lp.set_plan(plan)
    ok, _, reason = lp.compute_velocity(cm, (2.5, 2.5, 0.0), (0.0, 0.0, 0.0), plan)
    assert ok and reason != TURNING_TO_PLAN


def test_the_user_the_robot_is_sent_to_is_kept_at_approach_person_distance():
    """Florence: a goal 0.5 m in front of a seated user (approach_me_map's), xy_goal_tolerance 0.05 m.
    With min_person_distance 0.6 the local planner will not drive within 0.6 m of her and reports
    the person; announced as the person the robot is sent to (set_people's ``approached``,
    move_base/approach_target; her track 0.07 m off), she is kept at approach_person_distance 0.45 m
    and the robot reaches the goal. approach_person_distance unset: her too at 0.6 m."""
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(5.0, 5.0, 5.7, 5.0, yaw_end=0.0)
    her = np.array([[6.2, 5.0, 0.0, 0.0]])

    def drive(approached, **params):
        lp = planner(min_person_distance=0.6, xy_goal_tolerance=0.05, **params)
        lp.set_plan(plan)
        x, v, reason = 5.0, 0.0, ""
        for _ in range(80):
            lp.set_people(her, approached=approached)
            ok, cmd, reason = lp.compute_velocity(cm, (x, 5.0, 0.0), (v, 0.0, 0.0), plan)
            v = cmd[0] if ok else 0.0
            x += v * 0.1
        return x, reason

    x, reason = drive(None, approach_person_distance=0.45)
    assert 6.2 - x >= 0.6 - 0.01 and "min_person_distance" in reason, (x, reason)
    x, reason = drive((6.25, 5.05), approach_person_distance=0.45)
    assert abs(x - 5.7) <= 0.05 + 1e-6 and reason == "goal reached", (x, reason)
    x, reason = drive((6.25, 5.05))
    assert 6.2 - x >= 0.6 - 0.01 and "min_person_distance" in reason, (x, reason)


def test_coming_round_the_user_she_is_kept_at_min_person_distance():
    """Florence: the goal 0.5 m beyond a seated user, the plan round her at 0.5 m (approach_me_map's
    pose at her front, the robot behind her). She is announced, but the robot is farther than
    approach_goal_radius from the goal: it keeps min_person_distance (0.6 m) from her on the way
    round; approach_person_distance (0.45 m) holds only on the last stretch. With the radius
    unbounded (the exemption everywhere, as before 29 Nov) it comes round her nearer than 0.6 m."""
    cm = Costmap2D(100, 100, 0.1)
    her = np.array([[6.2, 5.0, 0.0, 0.0]])
    a = np.linspace(math.pi, 0.0, 40)
    arc = np.column_stack([6.2 + 0.5 * np.cos(a), 5.0 + 0.5 * np.sin(a), a - math.pi / 2])
    arc[-1, 2] = math.pi  # at her other side, facing her
    plan = np.vstack([line_plan(4.6, 5.0, 5.65, 5.0), arc])

    def drive(**params):
        lp = planner(min_person_distance=0.6, approach_person_distance=0.45, xy_goal_tolerance=0.1, **params)
        lp.set_plan(plan)
        x, y, yaw, v, w, nearest = 4.6, 5.0, 0.0, 0.0, 0.0, math.inf
        for _ in range(300):
            lp.set_people(her, approached=(6.2, 5.0))
            ok, cmd, _reason = lp.compute_velocity(cm, (x, y, yaw), (v, 0.0, w), plan)
            v, w = (cmd[0], cmd[2]) if ok else (0.0, 0.0)
            yaw += w * 0.1
            x, y = x + v * math.cos(yaw) * 0.1, y + v * math.sin(yaw) * 0.1
            nearest = min(nearest, math.hypot(x - 6.2, y - 5.0))
        return nearest

    assert drive() >= 0.6 - 0.02
    assert drive(approach_goal_radius=10.0) < 0.58


@pytest.mark.parametrize("who", ["tracked", "unexplained", "nobody", "far"])
def test_near_person_speed_limits_the_forward_speed_near_people(who):
    """near_person_speed: within near_person_radius of a tracked person or of a leg-height return the
    maps do not explain, the robot drives no faster than near_person_speed; farther, at max_vel_x.
    Off by default (ROS)."""
    cm = Costmap2D(100, 100, 0.1)
    plan = line_plan(1.0, 5.0, 9.0, 5.0)
    beside = {"tracked": (3.0, 6.0), "unexplained": (3.0, 6.0), "far": (3.0, 6.5), "nobody": None}[who]

    def top_speed(**params):
        lp = planner(min_person_distance=0.6, acc_lim_x=0.5, **params)
        lp.set_plan(plan)
        pose, v, fastest = (2.0, 5.0, 0.0), np.zeros(3), 0.0
        for _ in range(int(4.0 / lp.params.sim_period)):  # 4 s: 1 m at most before it draws level
            people = np.array([[*beside, 0.0, 0.0]]) if who in ("tracked", "far") else np.zeros((0, 4))
            still = np.array([beside]) if who == "unexplained" else None
            lp.set_people(people, still=still)
            ok, cmd, _ = lp.compute_velocity(cm, pose, tuple(v), plan)
            assert ok
            if beside is None or math.dist(pose[:2], beside) <= (1.6 if who == "far" else 1.2):
                fastest = max(fastest, cmd[0])
            pose, v = _base_step(pose, v, cmd, (0.5, 0.5, 1.0), lp.params.sim_period)
        return fastest

    limited = top_speed(near_person_speed=0.3, near_person_radius=1.2)
    assert top_speed() > 0.45  # off: as ROS, also near her
    if who in ("nobody", "far"):  # far: 1.5 m beside its way at the nearest
        assert limited > 0.45
    else:  # within 1.2 m of her (1.0 m at the nearest) every command is within the limit
        assert 0.2 < limited <= 0.3 + 1e-9


def test_a_person_beside_the_robot_with_the_plan_leading_away_from_her_makes_it_turn_and_leave():
    """bench/nav.py --seed 2 (30 Nov): a resident walked up to the robot standing at its last goal,
    a leg 0.40 m from its centre on its left; the next goal lay 0.52 m the other way. The arcs toward
    it began by closing in on her, so the robot stopped for her, gave way 1 m the wrong way and came
    back: 16.6 s. Now it turns on the spot toward the plan, away from her, and drives off; with her
    where the plan leads it still stops for her."""
    cm = Costmap2D(100, 100, 0.1)
    start, goal = (2.21, 2.63, 0.69), (2.625, 2.325)
    plan = line_plan(start[0], start[1], *goal, yaw_end=-2.43)
    params = {"min_person_distance": 0.6, "acc_lim_th": 1.0, "turn_to_plan_angle": 1.5}

    def run(leg):
        lp = planner(**params)
        lp.set_plan(plan)
        pose, v, reasons, nearest = start, np.zeros(3), [], math.inf
        for _ in range(int(8.0 / lp.params.sim_period)):
            lp.set_people(np.zeros((0, 4)), still=np.array([leg]))
            ok, cmd, reason = lp.compute_velocity(cm, pose, tuple(v), plan)
            reasons.append(reason if ok else "stop: " + reason)
            pose, v = _base_step(pose, v, cmd, (0.5, 0.5, 1.0), lp.params.sim_period)
            nearest = min(nearest, math.dist(pose[:2], leg))
            if math.dist(pose[:2], goal) <= 0.25:
                return True, reasons, nearest
        return False, reasons, nearest

    reached, reasons, nearest = run((2.18, 3.03))
    assert reasons[0] == TURNING_AWAY and reached, reasons
    # no nearer to her than where she stepped up to it (0.401 m), but for the 0.01 m the rule allows
    # (people_layer.approaches' tolerance): the first arc, once the turn has begun, closes in by 0.01 m
    assert nearest >= 0.401 - 0.0125
    reached, reasons, _ = run((2.7, 2.9))  # on its way: it waits for her
    assert not reached and reasons[0].startswith("stop: ") and TURNING_AWAY not in reasons



def test_a_turn_away_from_people_once_per_place():
    """After a turn away from people has ended, the next waits until the robot has moved 0.25 m: in
    bench/nav.py --seed 2 a robot near a person arced off its plan, turned back toward it, arced off
    again, 40 s without getting 0.5 m on, and the goal aborted for oscillation."""
    cm = Costmap2D(100, 100, 0.1)
    start, goal = (2.21, 2.63, 0.69), (2.625, 2.325)
    plan = line_plan(start[0], start[1], *goal, yaw_end=-2.43)
    lp = planner(min_person_distance=0.6, acc_lim_th=1.0, turn_to_plan_angle=1.5)
    lp.set_plan(plan)

    def cycle(pose, leg):
        lp.set_people(np.zeros((0, 4)), still=np.array([leg]))
        return lp.compute_velocity(cm, pose, (0.0, 0.0, 0.0), plan)[2]

    assert cycle(start, (2.18, 3.03)) == TURNING_AWAY
    assert cycle(start, (2.18, 3.03)) == TURNING_AWAY  # the turn goes on
    assert cycle(start, (2.7, 2.9)) != TURNING_AWAY  # someone on the way on: it ends
    assert cycle(start, (2.18, 3.03)) != TURNING_AWAY  # not again here
    moved = (start[0] - 0.3, start[1], start[2])
    again = line_plan(moved[0], moved[1], *goal, yaw_end=-2.43)
    lp.set_people(np.zeros((0, 4)), still=np.array([(1.88, 3.03)]))
    assert lp.compute_velocity(cm, moved, (0.0, 0.0, 0.0), again)[2] == TURNING_AWAY  # 0.3 m on
