"""base_local_planner's TrajectoryPlanner: trajectory rollout and DWA (ROS-free).

The planner samples velocity commands (vx [m/s], vy [m/s], vtheta [rad/s]) in the base frame,
simulates each for ``sim_time`` [s] under the acceleration limits, and scores the end of every
legal trajectory with

    cost = path_distance_bias * path_dist + goal_distance_bias * goal_dist + occdist_scale * occ_cost

where ``path_dist`` / ``goal_dist`` [cells] come from two distance fields (a 4-connected
breadth-first search through non-obstacle cells, from the plan cells and from the local goal)
and ``occ_cost`` is the highest costmap cost met along the trajectory. A trajectory whose
footprint outline touches a lethal or unknown cell, or that leaves the map, is illegal
(cost -1); one that reaches a cell with no route to the plan or the goal is illegal (cost -2).

Semantics follow base_local_planner/src/trajectory_planner.cpp (ROS 1 navigation, noetic):
sampling order and tie rules of createTrajectories, generateTrajectory's step count and
integration, the in-place rotation choice by the goal distance ``heading_lookahead`` [m] ahead,
the oscillation flags and the escape (backing up) behaviour.

Poses are (x [m], y [m], yaw [rad]) in the costmap frame, REP 103 (x forward, y left, yaw
counter-clockwise).
"""

import dataclasses
import logging
import math

import numba
import numpy as np

from florence_common import angles
from florence_common.params import Param, ParamError, Params, ParamTable
from move_base.costmap_2d import NO_INFORMATION

log = logging.getLogger(__name__)

# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------

# Deprecated ROS names and the names that replace them (new names win when both are set).
_ALIASES = {
    "acc_lim_th": "acc_lim_theta",
    "min_in_place_rotational_vel": "min_in_place_vel_theta",
    "pdist_scale": "path_distance_bias",
    "gdist_scale": "goal_distance_bias",
    "backup_vel": "escape_vel",
}


def _numbers_problem(value):
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value):
        return "must be a list of finite numbers"
    return None


PARAMS = ParamTable(
    Param("acc_lim_x", float, 2.5, "forward acceleration limit", unit="m/s^2", gt=0.0),
    Param("acc_lim_y", float, 2.5, "sideways acceleration limit", unit="m/s^2", gt=0.0),
    Param("acc_lim_theta", float, 3.2, "rotational acceleration limit (old name acc_lim_th)", unit="rad/s^2",
          gt=0.0),
    Param("max_vel_x", float, 0.5, "fastest forward sample", unit="m/s", ge=0.0),
    Param("min_vel_x", float, 0.1, "slowest forward sample (at most max_vel_x)", unit="m/s"),
    Param("max_vel_theta", float, 1.0, "fastest rotation to the left (old name max_rotational_vel sets this and "
          "min_vel_theta = -max_rotational_vel)", unit="rad/s", ge=0.0),
    Param("min_vel_theta", float, -1.0, "fastest rotation to the right (negative)", unit="rad/s", le=0.0),
    Param("min_in_place_vel_theta", float, 0.4, "slowest in-place rotation commanded (at most max_vel_theta; old "
          "name min_in_place_rotational_vel)", unit="rad/s", ge=0.0),
    Param("escape_vel", float, -0.1, "velocity when backing up, negative (old name backup_vel)", unit="m/s"),
    Param("holonomic_robot", bool, True, "sample sideways velocities too"),
    Param("y_vels", list, [-0.3, -0.1, 0.1, 0.3], "pure strafe samples of a holonomic robot", unit="m/s",
          check=_numbers_problem),
    Param("sim_time", float, 1.0, "simulated time of each trajectory", unit="s", gt=0.0),
    Param("sim_granularity", float, 0.025, "step along a trajectory", unit="m", gt=0.0),
    Param("angular_sim_granularity", float, None, "angular step along a trajectory (unset: sim_granularity)",
          unit="rad", gt=0.0, optional=True),
    Param("vx_samples", int, 3, "forward velocity samples", ge=1),
    Param("vtheta_samples", int, 20, "rotational velocity samples", ge=1),
    Param("path_distance_bias", float, 0.6, "weight of the distance to the plan (old name pdist_scale)", ge=0.0),
    Param("goal_distance_bias", float, 0.8, "weight of the distance to the local goal (old name gdist_scale)",
          ge=0.0),
    Param("occdist_scale", float, 0.01, "weight of the highest cost along a trajectory", ge=0.0),
    Param("heading_lookahead", float, 0.325, "look-ahead for scoring in-place rotations", unit="m", ge=0.0),
    Param("heading_scoring", bool, False, "score the heading to the plan instead of the distance"),
    Param("heading_scoring_timestep", float, 0.8, "how far along the trajectory the heading is scored",
          unit="s", ge=0.0),
    Param("dwa", bool, True, "sample the window reachable in one control period, not in sim_time"),
    Param("simple_attractor", bool, False, "score by the squared distance to the goal only"),
    Param("meter_scoring", bool, False, "distances in metres (the biases times the resolution)"),
    Param("oscillation_reset_dist", float, 0.05, "travel that clears the oscillation flags", unit="m", ge=0.0),
    Param("escape_reset_dist", float, 0.10, "travel that ends an escape (backing up)", unit="m", ge=0.0),
    Param("escape_reset_theta", float, math.pi / 2, "rotation that ends an escape", unit="rad", ge=0.0),
    Param("xy_goal_tolerance", float, 0.10, "distance from the goal position that counts as reached", unit="m",
          ge=0.0),
    Param("yaw_goal_tolerance", float, 0.05, "difference from the goal yaw that counts as reached", unit="rad",
          ge=0.0),
    Param("latch_xy_goal_tolerance", bool, False, "once within xy_goal_tolerance, only turn to the goal yaw"),
    Param("prune_plan", bool, True, "drop the plan poses the robot has passed"),
    Param("trans_stopped_velocity", float, 0.1, "translation counted as stopped before the turn to the goal yaw",
          unit="m/s", ge=0.0),
    Param("rot_stopped_velocity", float, 0.1, "rotation counted as stopped before the turn to the goal yaw",
          unit="rad/s", ge=0.0),
    Param("controller_frequency", float, 20.0, "control rate: the DWA window and the braking steps are one period "
          "(not > 0: 0.05 s); unset, move_base's ~controller_frequency (ROS searchParam)", unit="Hz"),
    Param("final_approach_dist", float, 0.0, "Florence: within this distance of the goal, with the plan straight "
          "ahead, drive at the speed that can still brake at the goal (sqrt(2 acc_lim_x d)) and steer onto the "
          "plan (0: off, ROS)", unit="m", ge=0.0),
    Param("rotate_while_braking", bool, False, "Florence: within xy_goal_tolerance, start the turn to the goal yaw "
          "while braking (ROS stops first)"),
    Param("turn_before_tolerance", bool, False, "Florence, with rotate_while_braking: brake and turn before "
          "xy_goal_tolerance when a simulation of it ends well inside the tolerance and reaches the goal sooner"),
    Param("coast_to_goal_yaw", bool, False, "Florence: within xy_goal_tolerance, a robot still turning stops the "
          "turn once the turn it makes after a zero command (command_lag and the pose's age at its rate, then "
          "braking at acc_lim_theta) ends within half yaw_goal_tolerance short of the goal yaw or past it, and the "
          "goal is reached at rest within yaw_goal_tolerance (ROS: reached at any turn rate, and the robot coasts "
          "on past the goal yaw)"),
    Param("command_lag", float, 0.0, "Florence, coast_to_goal_yaw: time from the controller's command to the base "
          "acting on it (the filters between, the base's own cycle)", unit="s", ge=0.0),
    Param("turn_to_plan_angle", float, 0.0, "Florence: when the plan leads off more than this from the heading "
          "(toward its first pose 0.4 m away past the nearest), brake and turn on the spot toward it, one way "
          "until within a third of it (the shorter way unless only the longer is free), then drive; the next such "
          "turn once the robot has moved 0.25 m (0: off, ROS: the rollouts arc round, which in a doorway swung the "
          "robot to and fro)", unit="rad", ge=0.0),
    Param("min_person_distance", float, 0.0, "Florence: no trajectory brings the robot's centre nearer than this "
          "to a tracked person (walking on at their velocity), or nearer than this less 0.1 m to a leg-height "
          "return the maps do not explain, than braking would, nor (unless it is braking) than standing would; "
          "braking, turning on the spot and moving away stay allowed (0: off, ROS)", unit="m", ge=0.0),
    Param("walker_yield_speed", float, 0.0, "Florence, with min_person_distance: a tracked person walking at least "
          "this fast is given way to: while they would come within min_person_distance of a trajectory, "
          "whichever of the two closes in, only braking and turning on the spot are allowed (the robot stops "
          "while a walker passes near or comes up to it; 0: off)", unit="m/s", ge=0.0),
    Param("approach_person_distance", float, 0.0, "Florence: the person the robot is sent to on purpose "
          "(move_base's approach_target topic: approach_me_map's user) is kept this far instead of "
          "min_person_distance, and the leg-height returns round her are hers (0: min_person_distance for her "
          "too) ...", unit="m", ge=0.0),
    Param("approach_goal_radius", float, 0.35, "Florence: ... while the robot is this near its goal (farther out, "
          "coming round her, min_person_distance holds for her too)", unit="m", ge=0.0),
    Param("near_person_speed", float, 0.0, "Florence: the fastest forward speed while a tracked person's centre or "
          "a leg-height return the maps do not explain is within near_person_radius of the robot's centre (0: "
          "off, ROS)", unit="m/s", ge=0.0),
    Param("near_person_radius", float, 1.2, "Florence: ... (the outer edge of personal space)", unit="m", ge=0.0),
)
"""TrajectoryPlannerROS's parameters (``~TrajectoryPlannerROS/``: ROS names and defaults, plus
Florence's, off by default, which is ROS's behaviour)."""


class PlannerParams(Params):
    """TrajectoryPlannerROS's parameters (:data:`PARAMS`), validated, read-only, plus
    :attr:`sim_period`. ``PlannerParams(**values)`` takes current names only (unknown names are
    refused); :meth:`from_dict` reads a ``~TrajectoryPlannerROS`` dict with ROS's old names too.
    Raises ParamError (a ValueError) naming every bad parameter."""

    def __init__(self, **values):
        if isinstance(values.get("y_vels"), tuple):
            values["y_vels"] = list(values["y_vels"])
        p = dict(PARAMS.validate(values))
        if p["angular_sim_granularity"] is None:
            p["angular_sim_granularity"] = p["sim_granularity"]
        p["y_vels"] = tuple(float(v) for v in p["y_vels"])
        problems = []
        if p["min_vel_x"] > p["max_vel_x"]:
            problems.append(f"~min_vel_x ({p['min_vel_x']}) must not exceed ~max_vel_x ({p['max_vel_x']})")
        if p["min_in_place_vel_theta"] > p["max_vel_theta"]:
            problems.append(f"~min_in_place_vel_theta ({p['min_in_place_vel_theta']}) must not exceed "
                            f"~max_vel_theta ({p['max_vel_theta']})")
        if problems:
            raise ParamError("; ".join(problems))
        if p["escape_vel"] >= 0.0:
            log.warning("escape_vel %.3f m/s is not negative: the robot will move forward, not back up, "
                        "when it is stuck", p["escape_vel"])
        super().__init__(p)

    @property
    def sim_period(self):
        """Control period [s] used by DWA and the braking / rotate-to-goal steps: 1 /
        controller_frequency, 0.05 s when the frequency is not positive (as ROS)."""
        if self.controller_frequency > 0.0:
            return 1.0 / self.controller_frequency
        return 0.05

    @classmethod
    def from_dict(cls, d):
        """Parameters from a ``~TrajectoryPlannerROS`` dict (plus move_base's ``controller_frequency``).

        Accepts the deprecated names ``max_rotational_vel`` (sets max_vel_theta and
        min_vel_theta = -max), ``min_in_place_rotational_vel``, ``acc_lim_th``, ``pdist_scale``,
        ``gdist_scale`` and ``backup_vel``; the current names win when both are given. ``y_vels``
        may be a string "[-0.3, 0.3]". Unknown keys are ignored (logged at debug level). Raises
        ParamError naming a bad parameter.
        """
        d = dict(d or {})
        names = set(PARAMS.names())
        values = {}
        for old, new in _ALIASES.items():
            if old in d and new not in d:
                values[new] = d[old]
        if "max_rotational_vel" in d:
            mrv = d["max_rotational_vel"]
            if not isinstance(mrv, (int, float)) or isinstance(mrv, bool):
                raise ParamError(f"~max_rotational_vel must be a number, got {mrv!r}")
            values.setdefault("max_vel_theta", mrv)
            values.setdefault("min_vel_theta", -mrv)
        for key, value in d.items():
            if key in names:
                values[key] = value
            elif key not in _ALIASES and key != "max_rotational_vel":
                log.debug("ignoring parameter %s", key)
        if isinstance(values.get("y_vels"), str):
            text = values["y_vels"].replace("[", " ").replace("]", " ").replace(",", " ")
            try:
                values["y_vels"] = [float(t) for t in text.split()]
            except ValueError:
                raise ParamError(f"~y_vels must be a list of numbers, got {d['y_vels']!r}") from None
        return cls(**values)


# --------------------------------------------------------------------------------------------
# Grid kernels (numba)
# --------------------------------------------------------------------------------------------

wrap_nb = numba.njit(cache=True)(angles.wrap_scalar)
"""florence_common.angles.wrap_scalar for the kernels: an angle [rad] wrapped to [-pi, pi)."""


@numba.njit(cache=True)
def _cell(x, y, ox, oy, res, w, h):
    """Cell (mx, my) of a world point [m], (-1, -1) off the grid."""
    fx = (x - ox) / res
    fy = (y - oy) / res
    if fx < 0.0 or fy < 0.0:
        return -1, -1
    mx = math.floor(fx)
    my = math.floor(fy)
    if mx >= w or my >= h:
        return -1, -1
    return mx, my


@numba.njit(cache=True)
def _line_cost(costs, x0, y0, x1, y1, inscribed_is_obstacle):
    """Highest cost on the Bresenham line between two cells, -1 if a cell on it is an obstacle
    (lethal or unknown; also inscribed when ``inscribed_is_obstacle``)."""
    dx = abs(x1 - x0)
    dy = abs(y1 - y0)
    sx = 1 if x1 >= x0 else -1
    sy = 1 if y1 >= y0 else -1
    x = x0
    y = y0
    best = 0.0
    if dx >= dy:
        num = dx // 2
        for _ in range(dx + 1):
            c = costs[y, x]
            if c >= 254 or (inscribed_is_obstacle and c == 253):
                return -1.0
            if c > best:
                best = float(c)
            num += dy
            if num >= dx:
                num -= dx
                y += sy
            x += sx
    else:
        num = dy // 2
        for _ in range(dy + 1):
            c = costs[y, x]
            if c >= 254 or (inscribed_is_obstacle and c == 253):
                return -1.0
            if c > best:
                best = float(c)
            num += dx
            if num >= dy:
                num -= dy
                x += sx
            y += sy
    return best


@numba.njit(cache=True)
def _footprint_cost_nb(costs, ox, oy, res, x, y, yaw, fp):  # noqa: PLR0911 - early exits as ROS
    """CostmapModel::footprintCost: -1 if the centre is off the grid, a footprint vertex is off
    the grid or the outline crosses a lethal / unknown cell; else the highest outline cost.
    A footprint of fewer than 3 points is a circle: its centre cell decides (>= inscribed: -1)."""
    h, w = costs.shape
    cx, cy = _cell(x, y, ox, oy, res, w, h)
    if cx < 0:
        return -1.0
    n = fp.shape[0]
    if n < 3:
        c = costs[cy, cx]
        if c >= 253:
            return -1.0
        return float(c)
    c_ = math.cos(yaw)
    s_ = math.sin(yaw)
    fx0, fy0 = _cell(x + c_ * fp[0, 0] - s_ * fp[0, 1], y + s_ * fp[0, 0] + c_ * fp[0, 1], ox, oy, res, w, h)
    if fx0 < 0:
        return -1.0
    px, py = fx0, fy0
    best = 0.0
    for j in range(1, n + 1):
        if j < n:
            qx, qy = _cell(x + c_ * fp[j, 0] - s_ * fp[j, 1], y + s_ * fp[j, 0] + c_ * fp[j, 1], ox, oy, res, w, h)
            if qx < 0:
                return -1.0
        else:
            qx, qy = fx0, fy0
        lc = _line_cost(costs, px, py, qx, qy, False)
        if lc < 0.0:
            return -1.0
        best = max(best, lc)
        px, py = qx, qy
    return best


@numba.njit(cache=True)
def _footprint_mask_nb(costs, ox, oy, res, x, y, yaw, fp, mask):
    """Mark in ``mask`` the cells under the filled footprint at (x, y, yaw) (FootprintHelper::
    getFootprintCells with fill: outline cells, then every cell between the lowest and highest
    outline cell of each column). Cells off the grid are skipped."""
    h, w = costs.shape
    n = fp.shape[0]
    cx, cy = _cell(x, y, ox, oy, res, w, h)
    if n < 3:
        if cx >= 0:
            mask[cy, cx] = True
        return
    colmin = np.full(w, h, np.int64)
    colmax = np.full(w, -1, np.int64)
    c_ = math.cos(yaw)
    s_ = math.sin(yaw)
    for j in range(n):
        k = (j + 1) % n
        ax = (x + c_ * fp[j, 0] - s_ * fp[j, 1] - ox) / res
        ay = (y + s_ * fp[j, 0] + c_ * fp[j, 1] - oy) / res
        bx = (x + c_ * fp[k, 0] - s_ * fp[k, 1] - ox) / res
        by = (y + s_ * fp[k, 0] + c_ * fp[k, 1] - oy) / res
        x0 = math.floor(ax)
        y0 = math.floor(ay)
        x1 = math.floor(bx)
        y1 = math.floor(by)
        dx = abs(x1 - x0)
        dy = abs(y1 - y0)
        sx = 1 if x1 >= x0 else -1
        sy = 1 if y1 >= y0 else -1
        px = x0
        py = y0
        steps = max(dx, dy)
        num = steps // 2
        for _ in range(steps + 1):
            if 0 <= px < w and 0 <= py < h:
                mask[py, px] = True
                colmin[px] = min(colmin[px], py)
                colmax[px] = max(colmax[px], py)
            if dx >= dy:
                num += dy
                if num >= dx:
                    num -= dx
                    py += sy
                px += sx
            else:
                num += dx
                if num >= dy:
                    num -= dy
                    px += sx
                py += sy
    for px in range(w):
        for py in range(colmin[px], colmax[px] + 1):
            mask[py, px] = True


@numba.njit(cache=True)
def _propagate_nb(costs, within_robot, seeds_x, seeds_y):
    """MapGrid::computeTargetDistance: 4-connected breadth-first distance [cells] from the seed
    cells. Obstacle cells (inscribed, lethal, unknown; not under the robot) next to reached
    cells get size (obstacleCosts); cells never reached keep size + 1 (unreachableCellCosts)."""
    h, w = costs.shape
    size = h * w
    dist = np.full((h, w), size + 1.0)
    mark = np.zeros((h, w), np.bool_)
    queue = np.empty(size, np.int64)
    head = 0
    tail = 0
    for i in range(seeds_x.shape[0]):
        sx = seeds_x[i]
        sy = seeds_y[i]
        if not mark[sy, sx]:
            mark[sy, sx] = True
            dist[sy, sx] = 0.0
            queue[tail] = sy * w + sx
            tail += 1
    while head < tail:
        idx = queue[head]
        head += 1
        cy = idx // w
        cx = idx - cy * w
        d = dist[cy, cx] + 1.0
        for k in range(4):
            if k == 0:
                nx, ny = cx - 1, cy
            elif k == 1:
                nx, ny = cx + 1, cy
            elif k == 2:
                nx, ny = cx, cy - 1
            else:
                nx, ny = cx, cy + 1
            if nx < 0 or ny < 0 or nx >= w or ny >= h or mark[ny, nx]:
                continue
            mark[ny, nx] = True
            c = costs[ny, nx]
            if not within_robot[ny, nx] and c >= 253:
                dist[ny, nx] = float(size)
                continue
            dist[ny, nx] = min(dist[ny, nx], d)
            queue[tail] = ny * w + nx
            tail += 1
    return dist


@numba.njit(cache=True)
def _heading_diff_nb(costs, cx, cy, x, y, heading, plan_cx, plan_cy, ox, oy, res):
    """TrajectoryPlanner::headingDiff: |angle| [rad] between ``heading`` and the direction to the
    farthest plan cell in clear line of sight (inscribed cells block), DBL_MAX if none."""
    for i in range(plan_cx.shape[0] - 1, -1, -1):
        if _line_cost(costs, cx, cy, plan_cx[i], plan_cy[i], True) >= 0.0:
            gx = ox + (plan_cx[i] + 0.5) * res
            gy = oy + (plan_cy[i] + 0.5) * res
            return abs(wrap_nb(math.atan2(gy - y, gx - x) - heading))
    return 1.7976931348623157e308


@numba.njit(cache=True)
def _score_nb(points, n_steps, dts, costs, path_dist_map, goal_dist_map, fp, ox, oy, res, impossible,
              heading_scoring, hs_timestep, simple_attractor, goal_x, goal_y, plan_cx, plan_cy):
    """generateTrajectory's legality and score terms for every trajectory.

    Returns status (K,) (0 legal, -1 collision or off the grid, -2 no route to path/goal),
    n_valid (K,) points before the first illegal one, and path_dist, goal_dist, occ_cost,
    heading_diff (K,) of the last scored point.
    """
    k_count = points.shape[0]
    h, w = costs.shape
    status = np.zeros(k_count, np.int64)
    n_valid = np.zeros(k_count, np.int64)
    out_path = np.zeros(k_count)
    out_goal = np.zeros(k_count)
    out_occ = np.zeros(k_count)
    out_head = np.zeros(k_count)
    for k in range(k_count):
        path_dist = 0.0
        goal_dist = 0.0
        occ = 0.0
        head = 0.0
        t = 0.0
        dt = dts[k]
        st = 0
        n = 0
        for i in range(n_steps[k]):
            x = points[k, i, 0]
            y = points[k, i, 1]
            th = points[k, i, 2]
            cx, cy = _cell(x, y, ox, oy, res, w, h)
            if cx < 0:
                st = -1
                break
            fc = _footprint_cost_nb(costs, ox, oy, res, x, y, th, fp)
            if fc < 0.0:
                st = -1
                break
            c = float(costs[cy, cx])
            occ = max(occ, fc, c)
            if simple_attractor:
                goal_dist = (x - goal_x) * (x - goal_x) + (y - goal_y) * (y - goal_y)
            else:
                update = True
                if heading_scoring:
                    if t >= hs_timestep and t < hs_timestep + dt:
                        head = _heading_diff_nb(costs, cx, cy, x, y, th, plan_cx, plan_cy, ox, oy, res)
                    else:
                        update = False
                if update:
                    path_dist = path_dist_map[cy, cx]
                    goal_dist = goal_dist_map[cy, cx]
                    if impossible <= goal_dist or impossible <= path_dist:
                        st = -2
                        break
            n += 1
            t += dt
        status[k] = st
        n_valid[k] = n
        out_path[k] = path_dist
        out_goal[k] = goal_dist
        out_occ[k] = occ
        out_head[k] = head
    return status, n_valid, out_path, out_goal, out_occ, out_head


@numba.njit(cache=True)
def _step_velocity(vg, vi, a_max, dt):
    """computeNewVelocity for one value."""
    if vg - vi >= 0.0:
        return min(vg, vi + a_max * dt)
    return max(vg, vi - a_max * dt)


@numba.njit(cache=True)
def _rollout_nb(x, y, yaw, vx, vy, vth, samples, dts, t_max, acc_x, acc_y, acc_th):
    """Poses (K, t_max, 3) of every sample: record the pose, then step the velocities toward the
    sample under the acceleration limits and integrate (generateTrajectory's loop)."""
    k_count = samples.shape[0]
    pts = np.empty((k_count, t_max, 3))
    for k in range(k_count):
        dt = dts[k]
        px, py, pth = x, y, yaw
        vxi, vyi, vthi = vx, vy, vth
        for i in range(t_max):
            pts[k, i, 0] = px
            pts[k, i, 1] = py
            pts[k, i, 2] = pth
            vxi = _step_velocity(samples[k, 0], vxi, acc_x, dt)
            vyi = _step_velocity(samples[k, 1], vyi, acc_y, dt)
            vthi = _step_velocity(samples[k, 2], vthi, acc_th, dt)
            c = math.cos(pth)
            s = math.sin(pth)
            px += (vxi * c - vyi * s) * dt
            py += (vxi * s + vyi * c) * dt
            pth += vthi * dt
    return pts


@numba.njit(cache=True)
def _poses_free_nb(costs, ox, oy, res, poses, fp):
    """Whether :func:`_footprint_cost_nb` is legal (>= 0) at every pose (x, y, yaw) of ``poses``;
    stops at the first that is not."""
    for i in range(poses.shape[0]):
        if _footprint_cost_nb(costs, ox, oy, res, poses[i, 0], poses[i, 1], poses[i, 2], fp) < 0.0:
            return False
    return True


def poses_are_free(costmap, poses, footprint):
    """Whether the footprint is legal for :func:`footprint_cost` (no lethal or unknown cell on its
    outline, on the grid) at every pose (x [m], y [m], yaw [rad]) of ``poses`` (K, 3)."""
    return bool(_poses_free_nb(costmap.costs, costmap.origin_x, costmap.origin_y, costmap.resolution,
                               np.asarray(poses, dtype=float).reshape(-1, 3),
                               np.asarray(footprint, dtype=float).reshape(-1, 2)))


def footprint_cost(costmap, x, y, yaw, footprint):
    """Cost of the robot's footprint outline at (x [m], y [m], yaw [rad]) on ``costmap``, as
    base_local_planner's CostmapModel::footprintCost: -1.0 when the outline crosses a LETHAL or
    NO_INFORMATION cell or leaves the grid, else the highest cost on the outline cells.
    (A footprint of fewer than 3 points is a circle: -1.0 when its centre cell is >= INSCRIBED.)"""
    return float(_footprint_cost_nb(costmap.costs, costmap.origin_x, costmap.origin_y, costmap.resolution,
                                    float(x), float(y), float(yaw), np.asarray(footprint, dtype=float).reshape(-1, 2)))


def failure_counts(costs, padded_here, body_here):
    """Why every sample of a cycle failed, for the reason text: how many costs are -1 (an obstacle,
    an unknown cell or the grid's edge on the way), -2 (a cell the plan's distance fields do not
    reach) and PEOPLE_COST (too near a person), and the costs of the padded footprint and of the
    body where the robot stands (< 0: it touches one already)."""
    costs = np.asarray(costs, dtype=float)
    return {"samples": int(costs.size), "collide": int(np.sum(costs == -1.0)),
            "unreachable": int(np.sum(costs == -2.0)), "people": int(np.sum(costs == PEOPLE_COST)),
            "padded_here": float(padded_here), "body_here": float(body_here)}


def failure_text(counts):
    """The detail :func:`failure_counts` gives, in words."""
    here = ("the body touches an obstacle or unknown cell where it stands" if counts["body_here"] < 0 else
            "the padded footprint touches an obstacle or unknown cell where it stands" if counts["padded_here"] < 0
            else "the footprint is clear where it stands")
    return (f"{counts['collide']} of {counts['samples']} samples hit an obstacle or unknown cell, "
            f"{counts['unreachable']} leave the plan's reach, {counts['people']} come too near a person; {here}")


def adjust_plan_resolution(plan_xy, resolution):
    """MapGrid::adjustPlanResolution: insert points so consecutive plan points [m] are at most
    ``resolution`` [m] apart (``ceil(d / resolution)`` equal steps on a longer segment)."""
    plan_xy = np.asarray(plan_xy, dtype=float).reshape(-1, 2)
    if len(plan_xy) < 2:
        return plan_xy.copy()
    seg = np.diff(plan_xy, axis=0)
    d2 = np.einsum("ij,ij->i", seg, seg)
    steps = np.where(d2 > resolution * resolution, np.ceil(np.sqrt(d2) / resolution), 1.0).astype(np.int64)
    seg_index = np.repeat(np.arange(len(seg)), steps)
    # j = 1 .. steps within each segment
    j = np.arange(len(seg_index)) - np.repeat(np.cumsum(steps) - steps, steps) + 1
    frac = j / steps[seg_index]
    pts = plan_xy[seg_index] + frac[:, None] * seg[seg_index]
    ends = np.cumsum(steps) - 1
    pts[ends] = plan_xy[1:]  # the original points exactly
    return np.vstack([plan_xy[:1], pts])


def _plan_cells_run(costmap, plan_xy):
    """Cells of the adjusted plan points from the first one on the grid and known, up to the first
    one after it that is not (MapGrid::setTargetCells / setLocalGoal)."""
    pts = adjust_plan_resolution(plan_xy, costmap.resolution)
    if len(pts) == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    mx, my, inside = costmap.world_to_map(pts[:, 0], pts[:, 1])
    ok = inside.copy()
    ok[inside] = costmap.costs[my[inside], mx[inside]] != NO_INFORMATION
    if not ok.any():
        return np.empty(0, np.int64), np.empty(0, np.int64)
    first = int(np.argmax(ok))
    rest = ok[first:]
    stop = first + (int(np.argmin(rest)) if not rest.all() else len(rest))
    return mx[first:stop], my[first:stop]


# Kinds of samples, for the selection rules.
FORWARD, STRAFE_FORWARD, ROTATE, STRAFE, ESCAPE = range(5)


@dataclasses.dataclass
class Trajectory:
    """One scored sample: command (vx [m/s], vy [m/s], vtheta [rad/s]), cost, points (N, 3)."""

    vx: float
    vy: float
    vth: float
    cost: float
    points: np.ndarray


PEOPLE_COST = -3.0  # a trajectory refused for min_person_distance (Florence; the escape does not override it)
# [m] with min_person_distance set, no backing up (the escape included) while a tracked person stands this near
# behind the robot (Florence): the sensors do not see behind it, and in a corridor bench the robot that had
# turned its back on a person walking up to it backed into them
REAR_PERSON_DISTANCE = 1.5


class TrajectoryPlanner:
    """base_local_planner::TrajectoryPlanner on a :class:`Costmap2D`.

    Args:
        params: :class:`PlannerParams`.
        footprint: (N, 2) footprint [m] in the base frame (fewer than 3 points: circular robot).
        inscribed_radius, circumscribed_radius: [m], informational (ROS passes them on too).
        body: (M, 2) the robot's own outline [m] (the footprint without its margin; None: the
            footprint): what must stay clear while a robot already within the margin of an
            obstacle moves out of it, and end clear when it backs up out of a collision.
    """

    def __init__(self, params, footprint, inscribed_radius=0.0, circumscribed_radius=0.0, body=None):
        self.params = params
        self.footprint = np.asarray(footprint, dtype=float).reshape(-1, 2)
        self.body = self.footprint if body is None else np.asarray(body, dtype=float).reshape(-1, 2)
        self.failures = None  # failure_counts of the last cycle in which every sample failed, else None
        self.in_padding = False  # the robot stood within its padding, its body clear, this cycle
        self.inscribed_radius = float(inscribed_radius)
        self.circumscribed_radius = float(circumscribed_radius)
        self.path_dist = None  # (H, W) [cells] distance to the plan
        self.goal_dist = None  # (H, W) [cells] distance to the local goal
        self.local_goal = None  # (x, y) [m] of the local goal cell's centre
        self._plan_xy = np.empty((0, 2))
        self.last_trajectory = None  # the Trajectory chosen by the last find_best_command
        self.people = np.zeros((0, 4))  # (P, 4) x, y [m], vx, vy [m/s] in the costmap frame (min_person_distance)
        self.still_people = np.zeros((0, 2))  # (S, 2) x, y [m]: what may be people the tracker does not know
        self.remembered_people = np.zeros((0, 4))  # (R, 4): people seen longer ago, only for backs_toward
        self.people_distance = None  # (P,) [m] each person's min_person_distance (None: all the parameter's)
        self.speed_cap = math.inf  # [m/s] this cycle's limit on the forward samples (near_person_speed)
        self.refused_for_people = 0  # trajectories the last scoring refused for min_person_distance alone
        self._brake = None  # (x, y, yaw, vx, acc_lim_x) of the cycle: braking is never refused for people
        self._cost_without_people = None
        self.blocked_by_people = False  # the last cycle's best forward motion was refused for a person
        self.reset_oscillation_flags()
        self.escaping = False
        self.prev_x = self.prev_y = 0.0  # [m] where the last in-place move was chosen
        self.escape_x = self.escape_y = self.escape_theta = 0.0  # [m], [rad] where the escape began

    # --- state -----------------------------------------------------------------------------
    def reset_oscillation_flags(self):
        """Clear the oscillation flags. As in ROS, ``rotating_right`` / ``stuck_right`` belong to
        negative (clockwise) rotations and ``rotating_left`` / ``stuck_left`` to positive ones;
        ``stuck_left`` forbids negative rotation samples and ``stuck_right`` positive ones."""
        self.stuck_left = self.stuck_right = False
        self.stuck_left_strafe = self.stuck_right_strafe = False
        self.rotating_left = self.rotating_right = False
        self.strafe_left = self.strafe_right = False

    # --- sampling --------------------------------------------------------------------------
    def velocity_window(self, vx, vth, final_goal_dist=math.inf):
        """(min_vx, max_vx, min_vth, max_vth) sampled from current velocities vx [m/s], vth
        [rad/s]: reachable within sim_time (or sim_period with dwa) under the acceleration limits,
        clipped to the velocity limits; max_vx is also at most final_goal_dist [m] / sim_time."""
        p = self.params
        t = p.sim_period if p.dwa else p.sim_time
        max_vx = min(p.max_vel_x, self.speed_cap, final_goal_dist / p.sim_time)
        max_vx = max(min(max_vx, vx + p.acc_lim_x * t), p.min_vel_x)
        min_vx = max(p.min_vel_x, vx - p.acc_lim_x * t)
        if self.speed_cap < math.inf:  # near people: every forward sample within the cap (ROS: no clamp)
            min_vx = min(min_vx, max_vx)
        max_vth = min(p.max_vel_theta, vth + p.acc_lim_theta * t)
        min_vth = max(p.min_vel_theta, vth - p.acc_lim_theta * t)
        return min_vx, max_vx, min_vth, max_vth

    def sample_velocities(self, vx, vth, final_goal_dist=math.inf):
        """All samples in createTrajectories' order: (samples (K, 3), kinds (K,), raw_vth (K,),
        dvtheta). ``raw_vth`` is the rotation sample before min_in_place_vel_theta is applied
        (ROS tests it against dvtheta). The escape sample is always the last row."""
        p = self.params
        min_vx, max_vx, min_vth, max_vth = self.velocity_window(vx, vth, final_goal_dist)
        dvx = (max_vx - min_vx) / (p.vx_samples - 1) if p.vx_samples > 1 else 0.0
        dvth = (max_vth - min_vth) / (p.vtheta_samples - 1) if p.vtheta_samples > 1 else 0.0
        rows, kinds, raw = [], [], []
        if not self.escaping:
            vx_s = min_vx
            for _ in range(p.vx_samples):
                rows.append((vx_s, 0.0, 0.0))
                kinds.append(FORWARD)
                raw.append(0.0)
                vth_s = min_vth
                for _ in range(p.vtheta_samples - 1):
                    rows.append((vx_s, 0.0, vth_s))
                    kinds.append(FORWARD)
                    raw.append(vth_s)
                    vth_s += dvth
                vx_s += dvx
            if p.holonomic_robot:
                for vy_s in (0.1, -0.1):
                    rows.append((0.1, vy_s, 0.0))
                    kinds.append(STRAFE_FORWARD)
                    raw.append(0.0)
        vth_s = min_vth
        for _ in range(p.vtheta_samples):
            limited = max(vth_s, p.min_in_place_vel_theta) if vth_s > 0 else min(vth_s, -p.min_in_place_vel_theta)
            rows.append((0.0, 0.0, limited))
            kinds.append(ROTATE)
            raw.append(vth_s)
            vth_s += dvth
        if p.holonomic_robot:
            for vy_s in p.y_vels:
                rows.append((0.0, vy_s, 0.0))
                kinds.append(STRAFE)
                raw.append(0.0)
        rows.append((p.escape_vel, 0.0, 0.0))
        kinds.append(ESCAPE)
        raw.append(0.0)
        return np.array(rows, dtype=float), np.array(kinds), np.array(raw), dvth

    # --- rollout ---------------------------------------------------------------------------
    def num_steps(self, samples):
        """Steps per trajectory (generateTrajectory): the larger of distance / sim_granularity and
        |vtheta| / angular_sim_granularity, rounded, at least 1 (sim_time / sim_granularity with
        heading scoring)."""
        p = self.params
        samples = np.asarray(samples, dtype=float).reshape(-1, 3)
        if p.heading_scoring:
            n = np.full(len(samples), int(p.sim_time / p.sim_granularity + 0.5))
        else:
            vmag = np.hypot(samples[:, 0], samples[:, 1])
            n = np.floor(np.maximum(vmag * p.sim_time / p.sim_granularity,
                                    np.abs(samples[:, 2]) / p.angular_sim_granularity) + 0.5).astype(np.int64)
        return np.maximum(n, 1)

    def generate_trajectories(self, x, y, yaw, vx, vy, vth, samples):
        """Simulate every sample from pose (x [m], y [m], yaw [rad]) and velocity (vx, vy [m/s],
        vth [rad/s]): each step first records the pose, then moves each velocity toward the sample
        by at most acc_lim * dt and integrates x += (vx cos yaw - vy sin yaw) dt, y += (vx sin yaw
        + vy cos yaw) dt, yaw += vth dt, with dt = sim_time / steps.

        Returns points (K, T, 3) (rows past a trajectory's step count repeat nothing useful),
        steps (K,) and dt (K,) [s].
        """
        p = self.params
        samples = np.asarray(samples, dtype=float).reshape(-1, 3)
        k = len(samples)
        steps = self.num_steps(samples)
        dt = p.sim_time / steps
        t_max = int(steps.max()) if k else 1
        pts = _rollout_nb(float(x), float(y), float(yaw), float(vx), float(vy), float(vth), samples, dt, t_max,
                          float(p.acc_lim_x), float(p.acc_lim_y), float(p.acc_lim_theta))
        return pts, steps, dt

    # --- maps ------------------------------------------------------------------------------
    def update_plan(self, costmap, plan_xy, x, y, yaw):
        """Compute the path and goal distance fields [cells] for the plan (N, 2) [m] in the costmap
        frame, with the robot at (x, y, yaw): cells under its footprint never block the path
        field (findBestPath's within_robot)."""
        plan_xy = np.asarray(plan_xy, dtype=float).reshape(-1, 2)
        self._plan_xy = plan_xy
        costs = costmap.costs
        within = np.zeros(costs.shape, dtype=np.bool_)
        _footprint_mask_nb(costs, costmap.origin_x, costmap.origin_y, costmap.resolution,
                           float(x), float(y), float(yaw), self.footprint, within)
        cx, cy = _plan_cells_run(costmap, plan_xy)
        if len(cx) == 0:
            log.error("none of the %d points of the plan are in the local costmap and known", len(plan_xy))
            size = costs.size
            self.path_dist = np.full(costs.shape, size + 1.0)
            self.goal_dist = np.full(costs.shape, size + 1.0)
            self.local_goal = None
            return
        self.path_dist = _propagate_nb(costs, within, cx.astype(np.int64), cy.astype(np.int64))
        no_robot = np.zeros(costs.shape, dtype=np.bool_)
        self.goal_dist = _propagate_nb(costs, no_robot, cx[-1:].astype(np.int64), cy[-1:].astype(np.int64))
        self.local_goal = costmap.map_to_world(int(cx[-1]), int(cy[-1]))

    def score_trajectories(self, costmap, points, steps, dt):
        """Costs (K,) and legal point counts (K,) of simulated trajectories (generateTrajectory's
        scoring) on the fields of the last :meth:`update_plan`. Negative cost: illegal (-1
        collision / off the map, -2 no route to the plan or goal)."""
        p = self.params
        costs = costmap.costs
        plan = self._plan_xy
        goal_x, goal_y = (float(plan[-1, 0]), float(plan[-1, 1])) if len(plan) else (0.0, 0.0)
        if p.heading_scoring and len(plan):
            mx, my, inside = costmap.world_to_map(plan[:, 0], plan[:, 1])
            pcx, pcy = mx[inside].astype(np.int64), my[inside].astype(np.int64)
        else:
            pcx = pcy = np.empty(0, np.int64)
        impossible = float(costs.size)  # MapGrid::obstacleCosts
        steps = np.asarray(steps, np.int64)

        def score(footprint):
            return _score_nb(np.ascontiguousarray(points), steps, np.asarray(dt, float), costs, self.path_dist,
                             self.goal_dist, footprint, costmap.origin_x, costmap.origin_y, costmap.resolution,
                             impossible, bool(p.heading_scoring), float(p.heading_scoring_timestep),
                             bool(p.simple_attractor), goal_x, goal_y, pcx, pcy)

        scored = score(self.footprint)
        if self.in_padding:
            scored = self._out_of_padding(costmap, points, steps, scored, score(self.body))
        status, n_valid, path_d, goal_d, occ, head = scored
        pdist_scale, gdist_scale = p.path_distance_bias, p.goal_distance_bias
        if p.meter_scoring:
            pdist_scale *= costmap.resolution
            gdist_scale *= costmap.resolution
        cost = pdist_scale * path_d + gdist_scale * goal_d + p.occdist_scale * occ
        if p.heading_scoring:
            cost = cost + 0.3 * head
        cost = np.where(status == 0, cost, status.astype(float))
        self.refused_for_people = 0
        self._cost_without_people = cost
        if p.min_person_distance > 0.0 and (len(self.people) or len(self.still_people) or len(self.remembered_people)):
            from move_base.people_layer import approaches, backs_toward

            index = np.arange(points.shape[1])[None, :]
            times = np.where(index < steps[:, None], index * np.asarray(dt, float).reshape(-1, 1), np.inf)
            near = approaches(points, times, self.people, p.min_person_distance, brake=self._brake,
                              still=self.still_people, per_person=self.people_distance,
                              yield_speed=p.walker_yield_speed)
            # nor backing up toward a person behind (out of the sensors' view), the escape included
            # (its collision cost -1 would turn into a licence to back up)
            rear = np.vstack([self.people.reshape(-1, 4), self.remembered_people.reshape(-1, 4)])
            back = backs_toward(points, rear, REAR_PERSON_DISTANCE) & ((cost >= 0.0) | (cost == -1.0))
            self.refused_for_people = int(np.count_nonzero((near | back) & (cost >= 0.0)))
            cost = np.where((near & (cost >= 0.0)) | back, PEOPLE_COST, cost)
        return cost, n_valid

    def _out_of_padding(self, costmap, points, steps, padded, body):
        """Florence: the robot already nearer an obstacle than its footprint's padding, its body
        clear (a person stepped up to it, it stopped askew in a door), fails every sample at the
        first pose, and could only back up. A trajectory is legal when the body stays clear along
        it and the padded footprint is clear at its end (out of the margin within sim_time): the
        scores of ``body`` replace those of ``padded`` (both :func:`_score_nb` tuples) there."""
        ends = points[np.arange(len(points)), np.maximum(steps - 1, 0)]
        ends_clear = np.array([footprint_cost(costmap, ex, ey, eth, self.footprint) >= 0
                               for ex, ey, eth in ends[:, :3]], dtype=bool)
        use = (padded[0] == -1) & (body[0] == 0) & ends_clear
        return tuple(np.where(use, b, a) for a, b in zip(padded, body, strict=True))

    def _note_padding(self, costmap, x, y, yaw):
        """Whether the robot stands within its padding, its body clear (see :meth:`_out_of_padding`)."""
        self.in_padding = (self.body is not self.footprint
                           and footprint_cost(costmap, x, y, yaw, self.footprint) < 0
                           <= footprint_cost(costmap, x, y, yaw, self.body))

    def check_trajectory(self, costmap, x, y, yaw, vx, vy, vth, vx_samp, vy_samp, vth_samp):
        """True when the command (vx_samp, vy_samp, vth_samp) simulated from the current pose and
        velocity is legal (TrajectoryPlanner::checkTrajectory; needs :meth:`update_plan` first)."""
        pts, steps, dt = self.generate_trajectories(x, y, yaw, vx, vy, vth, [(vx_samp, vy_samp, vth_samp)])
        self._note_padding(costmap, x, y, yaw)
        self._brake = (float(x), float(y), float(yaw), float(vx), float(self.params.acc_lim_x))
        cost, _ = self.score_trajectories(costmap, pts, steps, dt)
        return bool(cost[0] >= 0.0)

    # --- selection -------------------------------------------------------------------------
    def find_best_command(self, costmap, x, y, yaw, vx, vy, vth, plan_xy, goal_xy=None):
        """One control cycle of findBestPath / createTrajectories.

        Args:
            costmap: the local :class:`Costmap2D`.
            x, y, yaw: robot pose [m, m, rad] in the costmap frame.
            vx, vy, vth: current base-frame velocity [m/s, m/s, rad/s].
            plan_xy: (N, 2) plan [m] in the costmap frame (pruned and clipped to the costmap).
            goal_xy: final goal (x, y) [m] limiting max_vel_x to distance / sim_time; by default
                the plan's last point (ROS: the last pose of the plan handed to the planner).

        Returns:
            (cmd (vx, vy, vth), cost, points (N, 3)): cost < 0 means no legal trajectory and a
            zero command. An escape (backing up) returns cost 1.0 even when it collides, as ROS, if
            the robot's body (the footprint without its padding) ends clear at its last pose
            (Florence: ROS backs into what is behind the robot too; the padded footprint would keep
            a robot a few degrees askew in a doorway from backing out of it, the padding touching a
            jamb, and a person it met there waiting for it for ever).
        """
        plan_xy = np.asarray(plan_xy, dtype=float).reshape(-1, 2)
        self.update_plan(costmap, plan_xy, x, y, yaw)
        self._note_padding(costmap, x, y, yaw)
        self._brake = (float(x), float(y), float(yaw), float(vx), float(self.params.acc_lim_x))
        if goal_xy is None and len(plan_xy):
            goal_xy = plan_xy[-1]
        final_goal_dist = math.hypot(goal_xy[0] - x, goal_xy[1] - y) if goal_xy is not None else math.inf

        samples, kinds, raw_vth, dvth = self.sample_velocities(vx, vth, final_goal_dist)
        pts, steps, dt = self.generate_trajectories(x, y, yaw, vx, vy, vth, samples)
        costs, n_valid = self.score_trajectories(costmap, pts, steps, dt)
        best = self._select(costmap, samples, kinds, raw_vth, dvth, costs, pts, n_valid, x, y, yaw)
        # a person in the way: the forward motion that would win without them is refused for them,
        # and what is left is turning on the spot or backing up
        self.blocked_by_people = False
        if self.refused_for_people and kinds[best] not in (FORWARD, STRAFE_FORWARD):
            forward = np.flatnonzero((kinds == FORWARD) | (kinds == STRAFE_FORWARD))
            pre = self._cost_without_people[forward]
            legal = forward[pre >= 0]
            self.blocked_by_people = bool(len(legal)) and costs[legal[np.argmin(pre[pre >= 0])]] < 0
        traj = Trajectory(float(samples[best, 0]), float(samples[best, 1]), float(samples[best, 2]),
                          float(costs[best]), pts[best, : n_valid[best]].copy())
        if kinds[best] == ESCAPE:
            end = pts[best, max(int(steps[best]) - 1, 0)]
            ends_free = footprint_cost(costmap, float(end[0]), float(end[1]), float(end[2]), self.body) >= 0
            traj.cost = self._escape_bookkeeping(traj.cost, x, y, yaw, ends_free)
        self.last_trajectory = traj
        if traj.cost < 0:
            self.failures = failure_counts(costs, footprint_cost(costmap, x, y, yaw, self.footprint),
                                           footprint_cost(costmap, x, y, yaw, self.body))
            return (0.0, 0.0, 0.0), traj.cost, traj.points
        self.failures = None
        return (traj.vx, traj.vy, traj.vth), traj.cost, traj.points

    def _select(self, costmap, samples, kinds, raw_vth, dvth, costs, pts, n_valid, x, y, yaw):
        """Index of the chosen sample, with the oscillation bookkeeping of createTrajectories."""
        p = self.params
        best = -1
        best_cost = -1.0
        # Forward samples: "comp.cost >= 0 && (comp.cost < best.cost || best.cost < 0)", so the first
        # of equal minima wins.
        forward = np.flatnonzero((kinds == FORWARD) | (kinds == STRAFE_FORWARD))
        legal = forward[costs[forward] >= 0]
        if len(legal):
            best = int(legal[np.argmin(costs[legal])])  # argmin returns the first of equal minima
            best_cost = float(costs[best])

        # In-place rotations toward open space: the goal distance heading_lookahead ahead decides.
        heading_dist = math.inf
        for i in np.flatnonzero(kinds == ROTATE):
            vth_samp = raw_vth[i]
            best_strafes = best >= 0 and samples[best, 1] != 0.0
            if not (costs[i] >= 0 and (costs[i] <= best_cost or best_cost < 0 or best_strafes)
                    and (vth_samp > dvth or vth_samp < -dvth)):
                continue
            ex, ey, eth = pts[i, n_valid[i] - 1]
            cell = costmap.world_to_map(ex + p.heading_lookahead * math.cos(eth),
                                        ey + p.heading_lookahead * math.sin(eth))
            if cell is None:
                continue
            ahead = float(self.goal_dist[cell[1], cell[0]])
            if ahead < heading_dist and ((vth_samp < 0 and not self.stuck_left)
                                         or (vth_samp > 0 and not self.stuck_right)):
                best, best_cost, heading_dist = int(i), float(costs[i]), ahead

        if best_cost >= 0:
            self._after_choice(samples[best], x, y, yaw, strafe_block=False)
            return best

        # Pure strafes of a holonomic robot, when nothing forward or rotating is legal.
        if p.holonomic_robot:
            for i in np.flatnonzero(kinds == STRAFE):
                if not (costs[i] >= 0 and (costs[i] <= best_cost or best_cost < 0)):
                    continue
                ex, ey, eth = pts[i, n_valid[i] - 1]
                cell = costmap.world_to_map(ex + p.heading_lookahead * math.cos(eth),
                                            ey + p.heading_lookahead * math.sin(eth))
                if cell is None:
                    continue
                ahead = float(self.goal_dist[cell[1], cell[0]])
                vy_samp = samples[i, 1]
                if ahead < heading_dist and ((vy_samp > 0 and not self.stuck_left_strafe)
                                             or (vy_samp < 0 and not self.stuck_right_strafe)):
                    best, best_cost, heading_dist = int(i), float(costs[i]), ahead
            if best_cost >= 0:
                self._after_choice(samples[best], x, y, yaw, strafe_block=True)
                return best

        return len(samples) - 1  # the escape sample

    def _after_choice(self, sample, x, y, yaw, strafe_block):
        """Oscillation flags after a legal choice (trajectory_planner.cpp, the two blocks).

        After a rotation or strafe (no forward motion), a rotation in the same direction as the
        previous one sets that direction's stuck flag, which forbids the opposite direction until
        the robot has moved oscillation_reset_dist: negative vtheta twice -> stuck_right -> no
        positive rotation; positive twice -> stuck_left -> no negative rotation. Pure strafes
        (second block) use the crossed rule: +vy after -vy -> stuck_right_strafe, and so on.
        """
        vx_s, vy_s, vth_s = sample
        if not vx_s > 0:
            if strafe_block:
                if vth_s < 0:
                    if self.rotating_right:
                        self.stuck_right = True
                    self.rotating_left = True
                elif vth_s > 0:
                    if self.rotating_left:
                        self.stuck_left = True
                    self.rotating_right = True
                elif vy_s > 0:
                    if self.strafe_right:
                        self.stuck_right_strafe = True
                    self.strafe_left = True
                elif vy_s < 0:
                    if self.strafe_left:
                        self.stuck_left_strafe = True
                    self.strafe_right = True
            elif vth_s < 0:
                if self.rotating_right:
                    self.stuck_right = True
                self.rotating_right = True
            elif vth_s > 0:
                if self.rotating_left:
                    self.stuck_left = True
                self.rotating_left = True
            elif vy_s > 0:
                if self.strafe_right:
                    self.stuck_right_strafe = True
                self.strafe_right = True
            elif vy_s < 0:
                if self.strafe_left:
                    self.stuck_left_strafe = True
                self.strafe_left = True
            self.prev_x, self.prev_y = x, y
        if math.hypot(x - self.prev_x, y - self.prev_y) > self.params.oscillation_reset_dist:
            self.reset_oscillation_flags()
        self._maybe_end_escape(x, y, yaw)

    def _maybe_end_escape(self, x, y, yaw):
        p = self.params
        if (math.hypot(x - self.escape_x, y - self.escape_y) > p.escape_reset_dist
                or abs(angles.diff(yaw, self.escape_theta)) > p.escape_reset_theta):
            self.escaping = False

    def _escape_bookkeeping(self, cost, x, y, yaw, ends_free=True):
        """State updates when backing up; returns the escape's reported cost. ``ends_free``: the
        backing trajectory's last pose is legal."""
        if math.hypot(x - self.prev_x, y - self.prev_y) > self.params.oscillation_reset_dist:
            self.reset_oscillation_flags()
        if not self.escaping and cost > -2.0:
            self.escape_x, self.escape_y, self.escape_theta = x, y, yaw
            self.escaping = True
        self._maybe_end_escape(x, y, yaw)
        # Back up even when the footprint touches an obstacle (ROS: "even when the static map shows
        # it as blocked"), so a robot whose nose touches something can back off it; Florence: only
        # when backing ends with the body clear of obstacles (ROS backed the robot into a table's
        # corner behind it)
        return 1.0 if cost == -1.0 and ends_free else cost
