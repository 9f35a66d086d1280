"""Tests of move_base.trajectory_planner (base_local_planner's TrajectoryPlanner), ROS-free.

References are computed independently in the tests: closed-form kinematics, a plain-Python
breadth-first search, hand-placed obstacles.
"""

import collections
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from move_base.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D
from move_base.footprint import pad_footprint, parse_footprint
from move_base.trajectory_planner import (
    ESCAPE,
    FORWARD,
    ROTATE,
    PlannerParams,
    TrajectoryPlanner,
    adjust_plan_resolution,
    footprint_cost,
    poses_are_free,
)

pytestmark = pytest.mark.unit

# The seed's files (turtlebot_control/config): footprint padded by footprint_padding, and
# base_local_planner_params.yaml with its old parameter names and its controller_frequency.
_CONFIG = Path(__file__).resolve().parents[2] / "turtlebot_control" / "config"
_COMMON = yaml.safe_load((_CONFIG / "costmap_common_params.yaml").read_text())
_LOCAL = yaml.safe_load((_CONFIG / "base_local_planner_params.yaml").read_text())
FOOTPRINT = pad_footprint(parse_footprint(_COMMON["footprint"]), _COMMON["footprint_padding"])
SEED = {**_LOCAL["TrajectoryPlannerROS"], "controller_frequency": _LOCAL["controller_frequency"]}


def seed_params(**over):
    d = dict(SEED)
    d.update(over)
    return PlannerParams.from_dict(d)


def straight_plan(x0, x1, y, step=0.05):
    n = round(abs(x1 - x0) / step) + 1
    return np.column_stack([np.linspace(x0, x1, n), np.full(n, y)])


# --- parameters ------------------------------------------------------------------------------

def test_from_dict_accepts_old_names():
    p = seed_params()
    assert p.max_vel_theta == 1.5 and p.min_vel_theta == -1.5
    assert p.min_in_place_vel_theta == 1.0
    assert p.acc_lim_theta == 3.0
    assert p.holonomic_robot is False and p.dwa is False
    assert p.sim_period == pytest.approx(0.2)
    assert p.angular_sim_granularity == p.sim_granularity == 0.025


def test_from_dict_new_names_win_and_defaults_are_ros():
    p = PlannerParams.from_dict({"acc_lim_th": 1.0, "acc_lim_theta": 2.0, "max_rotational_vel": 2.0,
                                 "min_vel_theta": -0.5, "pdist_scale": 0.1})
    assert p.acc_lim_theta == 2.0
    assert p.max_vel_theta == 2.0 and p.min_vel_theta == -0.5
    assert p.path_distance_bias == 0.1
    d = PlannerParams()
    assert (d.acc_lim_x, d.acc_lim_theta, d.max_vel_x, d.min_vel_x, d.escape_vel) == (2.5, 3.2, 0.5, 0.1, -0.1)
    assert (d.vx_samples, d.vtheta_samples, d.sim_time, d.dwa, d.holonomic_robot) == (3, 20, 1.0, True, True)
    assert (d.path_distance_bias, d.goal_distance_bias, d.occdist_scale) == (0.6, 0.8, 0.01)
    assert d.escape_reset_theta == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(("key", "value"), [
    ("sim_time", 0.0), ("acc_lim_x", -1.0), ("vx_samples", 0), ("vtheta_samples", 2.5),
    ("min_vel_x", 0.9), ("min_vel_theta", 0.5), ("holonomic_robot", "yes"), ("sim_granularity", float("nan")),
    ("xy_goal_tolerance", -0.1), ("max_rotational_vel", "fast"),
])
def test_from_dict_rejects_nonsense_naming_the_parameter(key, value):
    with pytest.raises(ValueError, match=key):
        PlannerParams.from_dict({key: value})


# --- sampling window -------------------------------------------------------------------------

@pytest.mark.parametrize(("dwa", "vx", "vth"), [(False, 0.0, 0.0), (False, 0.3, -0.5), (True, 0.0, 0.0),
                                                (True, 0.3, 0.4), (True, 0.45, 1.4)])
def test_velocity_window_is_reachable_under_acceleration_limits(dwa, vx, vth):
    p = seed_params(dwa=dwa)
    tp = TrajectoryPlanner(p, FOOTPRINT)
    t = 0.2 if dwa else 1.5  # 1 / controller_frequency or sim_time [s]
    samples, kinds, _, _ = tp.sample_velocities(vx, vth)
    fwd = samples[kinds == FORWARD]
    vxs = np.unique(np.round(fwd[:, 0], 9))
    lo = max(0.1, vx - 0.5 * t)
    hi = max(min(0.5, vx + 0.5 * t), 0.1)
    assert len(vxs) == (6 if hi > lo + 1e-9 else 1)
    assert vxs.min() == pytest.approx(lo) and vxs.max() == pytest.approx(hi)
    assert np.all(vxs >= 0.1 - 1e-9) and np.all(vxs <= 0.5 + 1e-9)
    # rotational samples of the forward block: vtheta_samples - 1 from the window's low end, plus 0
    vths = fwd[:6 * 20][:20, 2]
    th_lo = max(-1.5, vth - 3.0 * t)
    th_hi = min(1.5, vth + 3.0 * t)
    assert vths[0] == 0.0
    assert vths[1] == pytest.approx(th_lo)
    assert np.allclose(np.diff(vths[1:]), (th_hi - th_lo) / 19)
    # in-place rotations never slower than min_in_place_vel_theta
    rot = samples[kinds == ROTATE]
    assert np.all(rot[:, 0] == 0.0) and np.all(np.abs(rot[:, 2]) >= 1.0 - 1e-12)
    assert kinds[-1] == ESCAPE and samples[-1, 0] == pytest.approx(-0.1)


def test_max_vel_x_is_limited_by_distance_to_goal():
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    _, hi, _, _ = tp.velocity_window(0.5, 0.0, final_goal_dist=0.3)
    assert hi == pytest.approx(0.3 / 1.5)
    _, hi, _, _ = tp.velocity_window(0.5, 0.0, final_goal_dist=0.03)
    assert hi == pytest.approx(0.1)  # never below min_vel_x


def test_number_of_steps_follows_ros_rule():
    tp = TrajectoryPlanner(PlannerParams(sim_time=1.0, sim_granularity=0.025), FOOTPRINT)
    # distance 0.5 m / 0.025 = 20; |vth| 1.0 / 0.025 = 40 (ROS does not multiply by sim_time); zero -> 1
    assert list(tp.num_steps([(0.5, 0, 0), (0.1, 0, 1.0), (0, 0, 0)])) == [20, 40, 1]


# --- integration -----------------------------------------------------------------------------

@pytest.mark.parametrize(("v", "w"), [(0.3, 0.0), (0.3, 0.8), (0.2, -1.2), (0.0, 1.0)])
def test_trajectory_is_a_circular_arc_at_constant_velocity(v, w):
    p = PlannerParams(sim_time=1.5, sim_granularity=0.01)
    tp = TrajectoryPlanner(p, FOOTPRINT)
    x0, y0, th0 = 1.0, 2.0, 0.4
    pts, steps, dt = tp.generate_trajectories(x0, y0, th0, v, 0.0, w, [(v, 0.0, w)])
    n = steps[0]
    t = np.arange(n) * dt[0]
    if abs(w) < 1e-9:
        ex, ey = x0 + v * t * math.cos(th0), y0 + v * t * math.sin(th0)
    else:
        r = v / w
        ex = x0 + r * (np.sin(th0 + w * t) - math.sin(th0))
        ey = y0 - r * (np.cos(th0 + w * t) - math.cos(th0))
    eth = th0 + w * t
    tol = abs(v * w) * dt[0] * 1.5 * 2 + 1e-9  # first-order integration error bound [m]
    assert np.allclose(pts[0, :n, 0], ex, atol=tol)
    assert np.allclose(pts[0, :n, 1], ey, atol=tol)
    assert np.allclose(pts[0, :n, 2], eth, atol=1e-9)


def test_trajectory_accelerates_within_the_limit():
    p = PlannerParams(sim_time=1.0, sim_granularity=0.025, acc_lim_x=0.5)
    tp = TrajectoryPlanner(p, FOOTPRINT)
    pts, steps, dt = tp.generate_trajectories(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, [(0.5, 0.0, 0.0)])
    n, h = steps[0], dt[0]
    t = np.arange(n) * h
    s = 0.5 * 0.5 * t ** 2  # constant acceleration from rest, 0.5 m/s^2, never reaching 0.5 m/s in 1 s
    assert np.all(np.abs(pts[0, :n, 0] - s) <= 0.5 * h * t / 2 + 1e-9)
    assert np.all(np.diff(pts[0, :n, 0]) / h <= 0.5 * (t[1:] + h) + 1e-9)


# --- footprint and distance fields ------------------------------------------------------------

def test_footprint_cost_rules():
    cm = Costmap2D(40, 40, 0.05)
    x, y = 1.0, 1.0
    assert footprint_cost(cm, x, y, 0.0, FOOTPRINT) == 0.0
    nose = cm.world_to_map(x + 0.25, y)
    cm.costs[nose[1], nose[0]] = 100
    assert footprint_cost(cm, x, y, 0.0, FOOTPRINT) == 100.0
    cm.costs[nose[1], nose[0]] = INSCRIBED_INFLATED_OBSTACLE  # inscribed on the outline is legal (ROS)
    assert footprint_cost(cm, x, y, 0.0, FOOTPRINT) == 253.0
    for value in (LETHAL_OBSTACLE, NO_INFORMATION):
        cm.costs[nose[1], nose[0]] = value
        assert footprint_cost(cm, x, y, 0.0, FOOTPRINT) == -1.0
    cm.costs[:] = 0
    # a lethal cell strictly inside the outline is not seen by the outline test
    centre = cm.world_to_map(x, y)
    cm.costs[centre[1], centre[0]] = LETHAL_OBSTACLE
    assert footprint_cost(cm, x, y, 0.0, FOOTPRINT) == 0.0
    # off the grid
    assert footprint_cost(cm, 0.1, 1.0, 0.0, FOOTPRINT) == -1.0
    assert footprint_cost(cm, -1.0, 1.0, 0.0, FOOTPRINT) == -1.0
    # circular robot (fewer than 3 points): the centre cell decides, inscribed included
    cm.costs[centre[1], centre[0]] = INSCRIBED_INFLATED_OBSTACLE
    assert footprint_cost(cm, x, y, 0.0, np.zeros((1, 2))) == -1.0


def test_footprint_cost_agrees_with_layers_footprint_cost():
    layers = pytest.importorskip("move_base.layers")
    from move_base.footprint import transform_footprint

    rng = np.random.default_rng(3)
    cm = Costmap2D(60, 60, 0.05)
    cm.costs[:] = rng.choice([0, 50, 253, 254, 255], size=cm.costs.shape, p=[0.9, 0.04, 0.03, 0.02, 0.01])
    for _ in range(300):
        x, y, th = rng.uniform(0.0, 3.0), rng.uniform(0.0, 3.0), rng.uniform(-math.pi, math.pi)
        ref = layers.footprint_cost(cm, transform_footprint(FOOTPRINT, x, y, th), (x, y))
        got = footprint_cost(cm, x, y, th, FOOTPRINT)
        assert (got < 0) == (ref < 0), (x, y, th)
        if ref >= 0:
            assert got == ref


def test_poses_are_free_is_footprint_cost_at_every_pose():
    rng = np.random.default_rng(5)
    cm = Costmap2D(60, 60, 0.05)
    cm.costs[:] = rng.choice([0, 50, 253, 254, 255], size=cm.costs.shape, p=[0.98, 0.01, 0.004, 0.003, 0.003])
    legal = illegal = 0
    for _ in range(200):
        poses = np.column_stack([rng.uniform(0.0, 3.0, 4), rng.uniform(0.0, 3.0, 4), rng.uniform(-math.pi, math.pi, 4)])
        expected = all(footprint_cost(cm, *pose, FOOTPRINT) >= 0.0 for pose in poses)
        assert poses_are_free(cm, poses, FOOTPRINT) == expected, poses
        legal, illegal = legal + expected, illegal + (not expected)
    assert legal > 10 and illegal > 10  # both outcomes were tried
    assert poses_are_free(cm, np.empty((0, 3)), FOOTPRINT)


def _reference_bfs(costs, seeds, within):
    """Plain breadth-first distance [cells], 4-connected, for the test."""
    h, w = costs.shape
    size = h * w
    dist = np.full((h, w), size + 1.0)
    seen = np.zeros((h, w), bool)
    q = collections.deque()
    for sx, sy in seeds:
        if not seen[sy, sx]:
            seen[sy, sx] = True
            dist[sy, sx] = 0
            q.append((sx, sy))
    while q:
        cx, cy = q.popleft()
        for nx, ny in ((cx - 1, cy), (cx + 1, cy), (cx, cy - 1), (cx, cy + 1)):
            if 0 <= nx < w and 0 <= ny < h and not seen[ny, nx]:
                seen[ny, nx] = True
                if costs[ny, nx] >= 253 and not within[ny, nx]:
                    dist[ny, nx] = size
                    continue
                dist[ny, nx] = dist[cy, cx] + 1
                q.append((nx, ny))
    return dist


def test_distance_fields_match_a_reference_bfs():
    rng = np.random.default_rng(7)
    cm = Costmap2D(23, 17, 0.1)
    cm.costs[:] = rng.choice([0, 100, 253, 254, 255], size=cm.costs.shape, p=[0.7, 0.1, 0.1, 0.05, 0.05])
    cm.costs[8, :] = 0  # a free row for the plan
    tp = TrajectoryPlanner(PlannerParams(), FOOTPRINT)
    plan = straight_plan(0.05, 1.55, 0.85, step=0.1)
    tp.update_plan(cm, plan, 5.0, 5.0, 0.0)  # robot off the grid: nothing under its footprint
    seeds = [(int(px / 0.1), 8) for px in plan[:, 0]]
    nothing = np.zeros(cm.costs.shape, bool)
    assert np.array_equal(tp.path_dist, _reference_bfs(cm.costs, seeds, nothing))
    assert np.array_equal(tp.goal_dist, _reference_bfs(cm.costs, seeds[-1:], nothing))


def test_plan_resolution_is_adjusted():
    pts = adjust_plan_resolution([(0.0, 0.0), (0.35, 0.0), (0.4, 0.0)], 0.1)
    assert np.allclose(pts[:, 0], [0.0, 0.0875, 0.175, 0.2625, 0.35, 0.4])


# --- scoring and selection --------------------------------------------------------------------

def test_prefers_the_trajectory_along_the_path():
    cm = Costmap2D(100, 100, 0.1)
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    cmd, cost, pts = tp.find_best_command(cm, 2.0, 5.0, 0.0, 0.3, 0.0, 0.0, straight_plan(2.0, 7.0, 5.0))
    assert cost >= 0 and cmd[0] > 0.0 and cmd[2] == 0.0
    assert np.all(np.abs(pts[:, 1] - 5.0) < 1e-9) and pts[-1, 0] > 2.3
    # a path bending left: the robot turns left
    t = np.linspace(0, math.pi / 2, 60)
    bend = np.column_stack([2.0 + 1.0 * np.sin(t), 6.0 - 1.0 * np.cos(t)])
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    cmd, cost, _ = tp.find_best_command(cm, 2.0, 5.0, 0.0, 0.3, 0.0, 0.0, bend)
    assert cost >= 0 and cmd[2] > 0.0


def test_trajectories_hitting_an_obstacle_are_illegal():
    cm = Costmap2D(100, 100, 0.1)
    cm.costs[40:61, 29] = LETHAL_OBSTACLE  # wall across x in [2.9, 3.0) [m]
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    tp.update_plan(cm, straight_plan(2.0, 7.0, 5.0), 2.0, 5.0, 0.0)
    samples = [(0.1, 0.0, 0.0), (0.5, 0.0, 0.0)]
    pts, steps, dt = tp.generate_trajectories(2.0, 5.0, 0.0, 0.5, 0.0, 0.0, samples)
    cost, n_valid = tp.score_trajectories(cm, pts, steps, dt)
    # 0.1 m/s from 0.5 m/s: 0.31 m, nose at 2.56 m -> legal; 0.5 m/s for 1.5 s: 0.75 m -> hits
    assert cost[0] >= 0 and cost[1] == -1.0
    assert 0 < n_valid[1] < steps[1]
    assert np.all(pts[1, : n_valid[1], 0] + 0.25 < 2.9)
    _, cost, best = tp.find_best_command(cm, 2.0, 5.0, 0.0, 0.5, 0.0, 0.0, straight_plan(2.0, 7.0, 5.0))
    assert cost >= 0
    for x, y, th in best:
        assert footprint_cost(cm, x, y, th, FOOTPRINT) >= 0


def test_escape_when_boxed_in_then_leaves_escape_mode():
    cm = Costmap2D(100, 100, 0.1)
    cm.costs[45:56, 53] = LETHAL_OBSTACLE  # touches the nose outline at x = 5.25 .. 5.35
    cm.costs[45:56, 52] = LETHAL_OBSTACLE
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    plan = straight_plan(5.0, 8.0, 5.0)
    cmd, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cmd == (-0.1, 0.0, 0.0)
    assert cost == 1.0  # ROS backs up even though the footprint is in collision
    assert tp.escaping
    # while escaping, no forward samples
    _, kinds, _, _ = tp.sample_velocities(0.0, 0.0)
    assert FORWARD not in set(kinds)
    # away from the obstacle by more than escape_reset_dist with a legal choice: escape ends
    cm.costs[:] = 0
    tp.find_best_command(cm, 4.85, 5.0, 0.0, -0.1, 0.0, 0.0, plan)
    assert not tp.escaping


def test_no_escape_into_what_is_behind_the_robot():
    """Florence: boxed in as above, with a table's corner 0.1 m behind the robot's tail: backing up
    would end on it, so the planner gives no command (ROS backed into it)."""
    cm = Costmap2D(100, 100, 0.1)
    cm.costs[45:56, 53] = LETHAL_OBSTACLE
    cm.costs[45:56, 52] = LETHAL_OBSTACLE
    cm.costs[48:52, 47] = LETHAL_OBSTACLE  # x 4.7 .. 4.8: behind the tail (x 4.83)
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    cmd, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, straight_plan(5.0, 8.0, 5.0))
    assert cost < 0 and cmd == (0.0, 0.0, 0.0)


def test_no_escape_toward_a_person_behind_the_robot():
    """Florence: boxed in at the nose as above, a tracked person 1 m behind the robot (out of the
    sensors' view, where they may have walked up since): no backing up; 2 m behind, or in front
    beyond min_person_distance, it backs up as before."""
    cm = Costmap2D(100, 100, 0.1)
    cm.costs[45:56, 53] = LETHAL_OBSTACLE
    cm.costs[45:56, 52] = LETHAL_OBSTACLE
    for person, backs in (((4.0, 5.0), False), ((3.0, 5.0), True), ((6.2, 6.0), True)):
        tp = TrajectoryPlanner(seed_params(min_person_distance=0.6), FOOTPRINT)
        tp.people = np.array([[*person, 0.0, 0.0]])
        cmd, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, straight_plan(5.0, 8.0, 5.0))
        assert (cmd == (-0.1, 0.0, 0.0)) is backs, (person, cmd, cost)


def test_no_escape_toward_a_person_remembered_behind_the_robot():
    """Florence: the tracker dropped the person 1 m behind (out of view) but the global costmap
    still remembers them (remembered_people): no backing up toward them either; remembered 2 m
    behind, it backs up."""
    cm = Costmap2D(100, 100, 0.1)
    cm.costs[45:56, 53] = LETHAL_OBSTACLE
    cm.costs[45:56, 52] = LETHAL_OBSTACLE
    for person, backs in (((4.0, 5.0), False), ((3.0, 5.0), True)):
        tp = TrajectoryPlanner(seed_params(min_person_distance=0.6), FOOTPRINT)
        tp.remembered_people = np.array([[*person, 0.0, 0.0]])
        cmd, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, straight_plan(5.0, 8.0, 5.0))
        assert (cmd == (-0.1, 0.0, 0.0)) is backs, (person, cmd, cost)
    # a remembered person is no obstacle otherwise: in front, 0.5 m ahead, the robot still backs up
    tp = TrajectoryPlanner(seed_params(min_person_distance=0.6), FOOTPRINT)
    tp.remembered_people = np.array([[5.5, 5.0, 0.0, 0.0]])
    assert tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, straight_plan(5.0, 8.0, 5.0))[0] == (-0.1, 0.0, 0.0)


def test_escape_judges_its_end_by_the_body_not_the_padding():
    """Florence: the launch pads the footprint by 6 cm. Boxed in at the nose, with a jamb's
    corner beside the tail that the padding would touch after backing up but the robot's own
    outline does not (a robot a few degrees askew in a doorway): the escape is taken when the
    planner knows the body, refused when it judges by the padded footprint alone."""
    body = parse_footprint(_COMMON["footprint"])
    padded = pad_footprint(body, 0.06)
    cm = Costmap2D(200, 200, 0.05)
    cm.costs[90:111, 104:107] = LETHAL_OBSTACLE  # x 5.20 .. 5.35: the nose (5.24; padded 5.30) touches it
    cm.costs[104, 94] = LETHAL_OBSTACLE  # x 4.70 .. 4.75, y 5.20 .. 5.25: between the body's side and the padding's
    plan = straight_plan(5.0, 8.0, 5.0)
    assert footprint_cost(cm, 4.85, 5.0, 0.0, padded) < 0 <= footprint_cost(cm, 4.85, 5.0, 0.0, body)
    tp = TrajectoryPlanner(seed_params(), padded)
    cmd, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cost < 0 and cmd == (0.0, 0.0, 0.0)
    tp = TrajectoryPlanner(seed_params(), padded, body=body)
    cmd, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cmd == (-0.1, 0.0, 0.0) and cost == 1.0 and tp.escaping


def test_a_robot_within_its_padding_of_a_wall_drives_out_of_it():
    """Florence: the padded footprint (6 cm) touches a wall beside the robot, its body (1 cm) does
    not: every sample collides at its first pose for the padded footprint, so the planner alone
    would only back up (along the wall, still in it). A trajectory whose body stays clear and whose
    padded footprint ends clear is taken: the robot drives off the wall, toward its plan."""
    raw = parse_footprint(_COMMON["footprint"])
    body, padded = pad_footprint(raw, 0.01), pad_footprint(raw, 0.06)
    cm = Costmap2D(200, 200, 0.05)
    cm.costs[104, :] = LETHAL_OBSTACLE  # y 5.20 .. 5.25: the padded side (5.22) in it, the body's (5.17) not
    plan = np.column_stack([np.linspace(5.0, 8.0, 61), np.linspace(5.0, 3.5, 61)])
    assert footprint_cost(cm, 5.0, 5.0, 0.0, padded) < 0 <= footprint_cost(cm, 5.0, 5.0, 0.0, body)
    tp = TrajectoryPlanner(seed_params(), padded)
    cmd, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cmd[0] <= 0.0 and cmd[2] == 0.0  # nothing but the escape, backing along the wall
    tp = TrajectoryPlanner(seed_params(), padded, body=body)
    cmd, cost, points = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cost >= 0 and cmd[0] > 0.0 and cmd[2] < 0.0 and not tp.escaping
    assert all(footprint_cost(cm, x, y, th, body) >= 0 for x, y, th in points)
    assert footprint_cost(cm, *points[-1], padded) >= 0
    # clear of the padding, the padded footprint alone judges again
    cmd, cost, _ = tp.find_best_command(cm, 5.0, 4.9, 0.0, 0.0, 0.0, 0.0, plan)
    assert not tp.in_padding and cost >= 0


def test_no_route_to_the_goal_gives_a_negative_cost_and_zero_command():
    cm = Costmap2D(60, 60, 0.1)
    cm.costs[:, 35] = LETHAL_OBSTACLE  # a wall between the robot and the plan's end (the local goal)
    plan = straight_plan(3.0, 4.5, 3.0)
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    cmd, cost, _ = tp.find_best_command(cm, 3.0, 3.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cost == -2.0 and cmd == (0.0, 0.0, 0.0)
    assert not tp.escaping  # no escape without a route to the goal (ROS: cost > -2 required)
    cm.costs[:, 35] = 0
    cmd, cost, _ = tp.find_best_command(cm, 3.0, 3.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cost >= 0 and cmd[0] > 0


# --- oscillation suppression (regression: a sign error made the robot swing back and forth) ----

LEFT = (0.0, 0.0, 1.0)  # positive vtheta: counter-clockwise
RIGHT = (0.0, 0.0, -1.0)


def _allowed(tp):
    """(positive allowed, negative allowed) by the stuck flags (ROS: stuck_right forbids vtheta > 0,
    stuck_left forbids vtheta < 0)."""
    return not tp.stuck_right, not tp.stuck_left


def test_turning_left_twice_keeps_left_allowed():
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    tp._after_choice(LEFT, 1.0, 1.0, 0.0, strafe_block=False)
    assert _allowed(tp) == (True, True)
    tp._after_choice(LEFT, 1.0, 1.0, 0.2, strafe_block=False)
    pos, neg = _allowed(tp)
    assert pos, "a robot that turned left twice must still be allowed to turn left"
    assert not neg  # ... and may no longer swing back to the right


def test_left_right_left_forbids_swinging_right_until_moved():
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    tp._after_choice(LEFT, 1.0, 1.0, 0.0, strafe_block=False)
    tp._after_choice(RIGHT, 1.0, 1.0, 0.2, strafe_block=False)
    assert _allowed(tp) == (True, True)  # one reversal is allowed (ROS)
    tp._after_choice(LEFT, 1.0, 1.0, 0.0, strafe_block=False)
    assert _allowed(tp) == (True, False)  # a second reversal back to the right is not
    tp._after_choice((0.2, 0.0, 0.0), 1.03, 1.0, 0.0, strafe_block=False)
    assert _allowed(tp) == (True, False)  # moved 0.03 m < oscillation_reset_dist 0.05 m
    tp._after_choice((0.2, 0.0, 0.0), 1.06, 1.0, 0.0, strafe_block=False)
    assert _allowed(tp) == (True, True)


def _rotation_scene():
    """Wall just ahead of the nose (forward samples collide), plan going back to the left."""
    cm = Costmap2D(100, 100, 0.1)
    cm.costs[35:66, 53] = LETHAL_OBSTACLE
    plan = np.column_stack([np.linspace(5.0, 5.0, 30), np.linspace(5.0, 6.5, 30)])
    plan = np.vstack([plan, np.column_stack([np.linspace(5.0, 3.0, 40), np.full(40, 6.5)])])
    return cm, plan


def test_rotation_choice_repeats_and_respects_stuck_flags():
    cm, plan = _rotation_scene()
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    first, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cost >= 0 and first[0] == 0.0 and first[2] > 0.0  # turns left toward the plan
    second, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.3, 0.0, 0.0, first[2], plan)
    assert cost >= 0 and second[2] > 0.0, "turning left again must stay allowed"
    third, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.6, 0.0, 0.0, second[2], plan)
    assert cost >= 0 and third[2] > 0.0
    # with left rotations forbidden the planner turns right (or, if nothing else is legal, escapes)
    tp = TrajectoryPlanner(seed_params(), FOOTPRINT)
    tp.stuck_right = True
    cmd, cost, _ = tp.find_best_command(cm, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, plan)
    assert cmd[2] <= 0.0
