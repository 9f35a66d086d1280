"""TrajectoryPlannerROS: the local planner move_base calls every control cycle (ROS-free).

Wraps :class:`move_base.trajectory_planner.TrajectoryPlanner` with the parts of
base_local_planner's TrajectoryPlannerROS that are not ROS plumbing: the plan window
(transformGlobalPlan's clip to the local costmap, prunePlan), the goal tolerances and their
latch, braking (stopWithAccLimits) and the final in-place rotation to the goal yaw
(rotateToGoal).

Poses are (x [m], y [m], yaw [rad]); velocities (vx [m/s], vy [m/s], vtheta [rad/s]) in the base
frame; REP 103.
"""

import logging
import math

import numba
import numpy as np

from florence_common import angles
from move_base.people_layer import approach_exemption
from move_base.trajectory_planner import TrajectoryPlanner, failure_text, poses_are_free, wrap_nb

log = logging.getLogger(__name__)

_ZERO = (0.0, 0.0, 0.0)
NO_VALID_TRAJECTORY = "no valid trajectory (all samples collide)"
NO_VALID_TRAJECTORY_PEOPLE = "no valid trajectory: the others would come nearer than min_person_distance to a person"
# [m] within this of the goal position a turn to the goal yaw that collides is a failure; farther
# (at the edge of xy_goal_tolerance) the robot drives on toward the goal position first
_AT_GOAL = 0.05
# turn_to_plan_angle: the plan's direction is toward its first pose at least this far from the robot [m]
TURN_TO_PLAN_LOOKAHEAD = 0.4
# turn_to_plan_angle: after such a turn, the next only once the robot has moved this far [m]
TURN_TO_PLAN_AGAIN = 0.25
# turn_to_plan_angle: a turn under way goes on its way unless the plan swung round behind it and that
# way has more than a half turn and this [rad] left (then the other way, if free)
TURN_TO_PLAN_REVERSE = 0.5
# forward motion refused for people (_turn_away_from_people): the people within this [m] must all lie
# behind the plan's direction ...
AWAY_RADIUS = 1.5
# ... and the robot face more than this [rad] off it, for a turn on the spot toward the plan
AWAY_MIN_TURN = 0.3
TURNING_AWAY = "turning on the spot toward the plan, away from the people"
# [m] turn_before_tolerance starts only when the simulated stop is this far inside xy_goal_tolerance
_EARLY_MARGIN = 0.05
# fractions of acc_lim_x that turn_before_tolerance may brake at: braking gently from farther out
# starts the turn sooner and still stops inside the tolerance
_EARLY_DECELS = (1.0, 0.8, 0.65, 0.5)


def _sign(x):
    """base_local_planner's sign: -1 for negative values, +1 otherwise (zero included)."""
    return -1.0 if x < 0.0 else 1.0


def goal_turn_times(params, pose, v, w, goal, hold, decel, step=0.05, horizon=10.0):
    """Simulate options of the turn to the goal yaw near the goal: drive straight on at ``v``
    [m/s] for ``hold`` [s], then brake at ``decel`` [m/s^2] while turning toward the goal yaw as
    the local planner does (the turn rate heads for min(max_vel_theta, sqrt(2 acc_lim_theta
    |error|)) at acc_lim_theta), from ``pose`` (x, y, yaw) and turn rate ``w`` [rad/s], in steps of
    ``step`` [s]. ``hold`` and ``decel`` are arrays (or scalars) of the same shape, one option each.

    Returns (times, ends, poses, stops): per option the time [s] until the robot has been within
    xy_goal_tolerance of ``goal`` (x, y, yaw) and is within yaw_goal_tolerance of its yaw (inf
    beyond ``horizon`` or when it stops outside the tolerance) and the distance [m] from the goal
    where the translation stops; the poses (K, n, 3) of the steps and, per option, the number K_i
    of them it drove through before its translation stopped (or it reached the goal): option i's
    poses are ``poses[:K_i, i]``, the rest of its column is NaN.
    """
    p = params
    hold, decel = (np.ascontiguousarray(a.ravel()) for a in np.broadcast_arrays(
        np.asarray(hold, dtype=float), np.asarray(decel, dtype=float)))
    times, ends, poses, stops = _goal_turn_nb(
        float(pose[0]), float(pose[1]), float(pose[2]), float(v), float(w), float(goal[0]), float(goal[1]),
        float(goal[2]), hold, decel, float(step), round(horizon / step), float(p.xy_goal_tolerance),
        float(p.yaw_goal_tolerance), float(p.max_vel_theta), float(p.acc_lim_theta))
    return times, ends, poses[:stops.max(initial=0)], stops


@numba.njit(cache=True)
def _goal_turn_nb(x0, y0, yaw0, v0, w0, gx, gy, gth, hold, decel, step, nsteps, tol, yaw_tol, max_w, acc_w):
    """:func:`goal_turn_times`' simulation, one option after the other."""
    n = len(hold)
    times = np.full(n, np.inf)
    ends = np.full(n, np.nan)
    stops = np.zeros(n, dtype=np.int64)
    poses = np.full((nsteps + 1, n, 3), np.nan)
    for i in range(n):
        x, y, yaw, v, w = x0, y0, yaw0, v0, w0
        latched = False
        for k in range(nsteps + 1):
            dist = math.hypot(gx - x, gy - y)
            latched = latched or dist <= tol
            err = wrap_nb(gth - yaw)
            if latched and abs(err) <= yaw_tol:
                times[i] = k * step
                break
            if k * step >= hold[i]:
                v = max(0.0, v - decel[i] * step)
                want = math.copysign(min(max_w, math.sqrt(2.0 * acc_w * abs(err))), err)
                w = min(max(want, w - acc_w * step), w + acc_w * step)
                if v == 0.0 and np.isnan(ends[i]):
                    ends[i] = dist
                    if not latched:  # at rest outside the tolerance: a turn on the spot never gets in
                        break
            else:
                w = 0.0
            if np.isnan(ends[i]):
                poses[k, i, 0], poses[k, i, 1], poses[k, i, 2] = x, y, yaw
                stops[i] = k + 1
            x += v * math.cos(yaw) * step
            y += v * math.sin(yaw) * step
            yaw += w * step
        if np.isnan(ends[i]):  # reached before the translation stopped: where braking from here ends
            run = v * v / (2.0 * decel[i])
            ends[i] = math.hypot(gx - x - run * math.cos(yaw), gy - y - run * math.sin(yaw))
    return times, ends, poses, stops


def clip_plan(costmap, robot_xy, plan):
    """transformGlobalPlan's window: skip the plan poses farther than half the costmap's larger
    side [m] from the robot, then keep poses while they stay within that distance.

    Returns (window (M, 3), index of its first pose in ``plan``).
    """
    plan = np.asarray(plan, dtype=float).reshape(-1, 3)
    threshold = max(costmap.size_x * costmap.resolution, costmap.size_y * costmap.resolution) / 2.0
    near = np.hypot(plan[:, 0] - robot_xy[0], plan[:, 1] - robot_xy[1]) <= threshold
    if not near.any():
        return plan[:0], len(plan)
    first = int(np.argmax(near))
    rest = near[first:]
    stop = first + (len(rest) if rest.all() else int(np.argmin(rest)))
    return plan[first:stop], first


def plan_lookahead(window, x, y, lookahead=TURN_TO_PLAN_LOOKAHEAD):
    """(x, y) [m] of the first pose of ``window`` (N, 2+) at least ``lookahead`` [m] from the robot
    at (x, y), past the pose nearest it (the last pose when none is that far): where the plan
    leads from here."""
    d = np.hypot(window[:, 0] - x, window[:, 1] - y)
    nearest = int(np.argmin(d))
    ahead = nearest + np.flatnonzero(d[nearest:] >= lookahead)
    tx, ty = window[ahead[0], :2] if len(ahead) else window[-1, :2]
    return float(tx), float(ty)


def prune_count(robot_xy, plan):
    """prunePlan: how many leading plan poses to drop, stopping at the first one closer than
    1 m to the robot (all of them when none is)."""
    plan = np.asarray(plan, dtype=float).reshape(-1, 3)
    close = (plan[:, 0] - robot_xy[0]) ** 2 + (plan[:, 1] - robot_xy[1]) ** 2 < 1.0
    return int(np.argmax(close)) if close.any() else len(plan)


class LocalPlanner:
    """TrajectoryPlannerROS without ROS.

    Args:
        params: :class:`move_base.trajectory_planner.PlannerParams`.
        footprint: (N, 2) footprint [m] in the base frame.
        inscribed_radius, circumscribed_radius: footprint radii [m].
        body: (M, 2) the footprint without its padding [m] (None: the footprint), what must end
            clear when the robot backs up out of a collision (TrajectoryPlanner), and what a turn on
            the spot must keep clear (:meth:`_sweep_is_free`).

    Attributes:
        global_plan: (N, 3) plan [m, m, rad] in the global frame as set, pruned as the robot
            advances (ROS prunes its stored copy too).
        transformed_plan: (M, 3) the window of the plan used in the last cycle (costmap frame).
        local_plan: (K, 3) the chosen trajectory's poses of the last cycle (empty when rotating
            to the goal yaw or when no trajectory is legal), for display.
    """

    def __init__(self, params, footprint, inscribed_radius=0.0, circumscribed_radius=0.0, body=None):
        self.params = params
        self.planner = TrajectoryPlanner(params, footprint, inscribed_radius, circumscribed_radius, body=body)
        self.global_plan = np.empty((0, 3))
        self.transformed_plan = np.empty((0, 3))
        self.local_plan = np.empty((0, 3))
        self._xy_tolerance_latch = False
        self._rotating_to_goal = False
        self._turning_early = False  # turn_before_tolerance: braking and turning outside the tolerance
        self._reached_goal = False
        self._goal = None  # the last pose of the plan set last
        self._turn_to_plan = 0.0  # turn_to_plan_angle: the way of the turn on the spot under way (+1, -1; 0: none)
        self._turned_at = None  # turn_to_plan_angle: where the last such turn ended (x, y) [m]
        self._turning_away = False  # a turn on the spot away from people is under way (_turn_away_from_people)
        self._turned_away_at = None  # where the last one ended (x, y) [m]
        self._last_cmd = _ZERO  # the command of the last cycle
        self.pose_age = 0.0  # [s] how old the robot pose of the cycle is (set by the node; coast_to_goal_yaw)
        # Florence: with a person in the way (the forward motion that would win is refused for
        # min_person_distance), stop and say so instead of turning on the spot or backing up;
        # move_base clears it while it gives way
        self.stop_for_people = True
        self._still = np.zeros((0, 2))  # set_people's still points, before _exempt
        self._approached = None  # set_people's approached (x, y), None: nobody or approach_person_distance 0
        if params.turn_before_tolerance:  # compile (or load) the kernel now, not near the first goal
            goal_turn_times(params, (0.0, 0.0, 0.0), 0.0, 0.0, (0.0, 0.0, 0.0), 0.0, 1.0)

    def set_plan(self, poses, giving_way=False):
        """New global plan (N, 3) [m, m, rad]; clears the goal-reached flag. ``giving_way``: the
        plan leads out of people's way (the robot turns on the spot or backs up near them instead
        of stopping for them: see ``stop_for_people``).

        Every plan clears the oscillation flags and ends an escape, so a replan gives the robot
        that backed up (or was kept from turning back) a fresh start. A plan to a new goal also
        clears the xy goal latch and the rotation to the goal yaw; a plan that ends at the same goal
        pose (move_base replanning at planner_frequency) keeps them: ROS clears the latch on every
        setPlan, so with replanning the robot that had reached the goal position braked and drove
        again once a second instead of turning on the spot (measured in florence_sim: a 0.56 m leg
        with a half turn at the goal took 9.6 s, the turn stuttering between 1.0 rad/s and a stop)."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        same_goal = (self._goal is not None and len(poses) > 0
                     and np.allclose(poses[-1], self._goal, rtol=0.0, atol=1e-9))
        self.global_plan = poses.copy()
        self.stop_for_people = not giving_way
        self._goal = poses[-1].copy() if len(poses) else None
        self._reached_goal = False
        self.planner.reset_oscillation_flags()
        self.planner.escaping = False
        if not same_goal:
            self._turn_to_plan = 0.0
            self._turned_at = None
            self._turning_away, self._turned_away_at = False, None
            self._xy_tolerance_latch = False
            self._rotating_to_goal = False
            self._turning_early = False
        return True

    def is_goal_reached(self):
        """True once the robot was within both goal tolerances (since the last :meth:`set_plan`)."""
        return self._reached_goal

    def set_people(self, people, still=None, remembered=None, approached=None):
        """The tracked people for ``min_person_distance``: (P, 4) x, y [m], vx, vy [m/s] in the
        costmap frame of the next cycles; ``still`` (S, 2) [m]: points that may be people the
        tracker does not know (legs the laser sees where the map has nothing), kept at the same
        distance; ``remembered`` (R, 4): people seen longer ago (the global costmap's memory), only
        for the rule that the robot does not back up toward a person behind it; ``approached`` (x,
        y) [m]: where the person the robot is sent to stands (None: nobody), kept at
        ``approach_person_distance`` when that is set, while the robot is within
        ``approach_goal_radius`` of its goal (people_layer.approach_exemption; :meth:`_exempt`)."""
        p = self.params
        self.planner.people = np.asarray(people, dtype=float).reshape(-1, 4)
        self._still = np.zeros((0, 2)) if still is None else np.asarray(still, float).reshape(-1, 2)
        self._approached = approached if p.approach_person_distance > 0.0 else None
        self.planner.people_distance, self.planner.still_people = None, self._still
        self.planner.remembered_people = (np.zeros((0, 4)) if remembered is None
                                          else np.asarray(remembered, float).reshape(-1, 4))

    def _exempt(self, x, y, plan):
        """The person the robot is sent to (set_people's ``approached``) is kept at
        approach_person_distance only while the robot at (x, y) is within approach_goal_radius of the
        plan's goal: the last stretch to a pose 0.5 m from her. Farther out, coming round her (to her
        front, say), min_person_distance holds for her as for everybody: with 0.45 m there, the
        locator bench's robot passed 0.34-0.40 m from seated users (29 Nov)."""
        p = self.params
        self.planner.people_distance, self.planner.still_people = None, self._still
        if self._approached is None or not len(plan) or \
                math.hypot(plan[-1][0] - x, plan[-1][1] - y) > p.approach_goal_radius:
            return
        self.planner.people_distance, self.planner.still_people, _ = approach_exemption(
            self.planner.people, self._still, self._approached, p.approach_person_distance, p.min_person_distance)

    def _speed_cap(self, x, y):
        """``near_person_speed`` while a tracked person or a leg-height return the maps do not explain
        (set_people's; the person the robot is sent to included) is within ``near_person_radius`` of
        the robot at (x, y), else no limit. Why: min_person_distance judges an unexplained return as
        standing still, and a walker the tracker had not yet confirmed (Alice coming in from the
        laser's blind side across the robot's way) stopped a robot driving at 0.47 m/s 0.36 m from
        her centre, its bumper touching her (bench/nav.py seed 1, 29 Nov, leg 13). Slower, it stops
        sooner and she has time to see it."""
        p = self.params
        if p.near_person_speed <= 0.0:
            return math.inf
        points = np.vstack([self.planner.people[:, :2], np.asarray(self._still, dtype=float).reshape(-1, 2)])
        if len(points) and np.min(np.hypot(points[:, 0] - x, points[:, 1] - y)) <= p.near_person_radius:
            return p.near_person_speed
        return math.inf

    def compute_velocity(self, costmap, robot_pose, robot_vel, plan):
        """One control cycle (computeVelocityCommands).

        Args:
            costmap: the local :class:`Costmap2D`.
            robot_pose: (x [m], y [m], yaw [rad]) in the costmap frame.
            robot_vel: (vx [m/s], vy [m/s], vth [rad/s]) in the base frame (odometry).
            plan: :attr:`global_plan` transformed into the costmap frame, (N, 3), same order.

        Returns:
            (ok, cmd (vx, vy, vth), reason): ok False means no command could be computed (cmd is
            zero); reason says why (or what the robot is doing near the goal).
        """
        ok, cmd, reason = self._compute_velocity(costmap, robot_pose, robot_vel, plan)
        self._last_cmd = tuple(float(c) for c in cmd)
        return ok, cmd, reason

    def _compute_velocity(self, costmap, robot_pose, robot_vel, plan):  # noqa: PLR0911 - one return per outcome
        """:meth:`compute_velocity` without the record of the command."""
        p = self.params
        x, y, yaw = (float(v) for v in robot_pose)
        vx, vy, vth = (float(v) for v in robot_vel)
        plan = np.asarray(plan, dtype=float).reshape(-1, 3)
        self.local_plan = np.empty((0, 3))

        self._exempt(x, y, plan)
        self.planner.speed_cap = self._speed_cap(x, y)
        window, first = clip_plan(costmap, (x, y), plan)
        holds_goal = len(window) > 0 and first + len(window) == len(plan)  # the window ends at the goal
        if p.prune_plan and len(window):
            pruned = prune_count((x, y), window)
            window = window[pruned:]
            if pruned and len(self.global_plan) >= pruned:
                self.global_plan = self.global_plan[pruned:]
        self.transformed_plan = window
        if len(window) == 0:
            return False, _ZERO, "the plan has no pose within the local costmap"

        goal_x, goal_y, goal_th = window[-1]
        if self._xy_tolerance_latch or math.hypot(goal_x - x, goal_y - y) <= p.xy_goal_tolerance:
            self._turning_early = False
            self._turn_to_plan = 0.0
            if not self.stop_for_people:
                # giving way: the place is what counts; the turn to the goal yaw (the way the robot
                # came) took 2-4 s, and going on the robot turns toward its plan anyway
                self._reached_goal = True
                return True, _ZERO, "goal reached: out of the people's way"
            if p.latch_xy_goal_tolerance:
                self._xy_tolerance_latch = True
            angle = angles.diff(goal_th, yaw)
            verdict = self._goal_yaw_verdict(angle, vth)
            if verdict == "stop":
                return True, _ZERO, "stopping the turn: it coasts to the goal yaw"
            if verdict == "reached":
                self._rotating_to_goal = False
                self._xy_tolerance_latch = False
                self._reached_goal = True
                return True, _ZERO, "goal reached"
            # ROS runs a full cycle here too: it refreshes the distance fields checkTrajectory uses.
            best = self.planner.find_best_command(costmap, x, y, yaw, vx, vy, vth, window[:, :2])
            far = math.hypot(goal_x - x, goal_y - y) > _AT_GOAL
            # a turn under way is checked by _rotate_to_goal (the same sweep and its overshoot): once is enough
            if not far or self._rotating_to_goal or self._turn_is_free(costmap, x, y, yaw, goal_th):
                turn = self._turn_to_goal_yaw(costmap, x, y, yaw, vx, vy, vth, goal_th, far)
                if turn is not None:
                    return turn
            # Florence: a turn on the spot would collide here, at the edge of the tolerance (a goal
            # near a wall): drive on toward the goal position and turn there (ROS fails). Also when
            # the turn had begun and then became blocked (the costmap moved: a wall seen a cell
            # nearer, somebody close) or its braking overshoot would collide: replanning keeps the
            # turn, and it failed to an abort.
            self._rotating_to_goal = False
            self._xy_tolerance_latch = False

        else:
            cmd = self._turn_toward_plan(costmap, x, y, yaw, vx, vth, window)
            if cmd is not None:
                return True, cmd, "turning on the spot toward the plan"
            if holds_goal and p.turn_before_tolerance and p.rotate_while_braking and self.stop_for_people:
                cmd = self._turn_before_tolerance(costmap, x, y, yaw, vx, vy, vth, window[-1])
                if cmd is not None:
                    return True, cmd, "braking and turning to the goal yaw"
            if holds_goal and p.final_approach_dist > 0.0:
                cmd = self._final_approach(costmap, x, y, yaw, vx, vth, window)
                if cmd is not None:
                    return True, cmd, "final approach"
            best = self.planner.find_best_command(costmap, x, y, yaw, vx, vy, vth, window[:, :2])
        cmd, cost, points = best
        if self.stop_for_people and self.planner.blocked_by_people:
            turn = self._turn_away_from_people(costmap, x, y, yaw, vx, vth, window)
            if turn is not None:
                self._turning_away = True
                return True, turn, TURNING_AWAY
            self._end_turn_away(x, y)
            return False, _ZERO, NO_VALID_TRAJECTORY_PEOPLE
        self._end_turn_away(x, y)
        if cost < 0:
            log.debug("no legal trajectory (cost %.1f)", cost)
            if self.planner.refused_for_people:
                return False, _ZERO, NO_VALID_TRAJECTORY_PEOPLE
            # why each sample failed: the reason goes into the log, the WAITING text and the abort text
            detail = f": {failure_text(self.planner.failures)}" if self.planner.failures else ""
            return False, _ZERO, NO_VALID_TRAJECTORY + detail
        self.local_plan = points
        return True, cmd, ""

    # --- near the goal ---------------------------------------------------------------------
    def _turn_to_goal_yaw(self, costmap, x, y, yaw, vx, vy, vth, goal_th, far):
        """Inside the goal's xy tolerance: (ok, cmd, reason) that brakes, then turns on the spot to
        ``goal_th``, or None when the robot is ``far`` (> _AT_GOAL) from the goal position and the
        turn collides there (the caller drives on toward the goal position)."""
        p = self.params
        moving = (not self._stopped_moving(vx, vy) if p.rotate_while_braking
                  else not self._stopped(vx, vy, vth))
        if not self._rotating_to_goal and moving:
            if p.rotate_while_braking:
                cmd = self._brake_and_turn(costmap, x, y, yaw, vx, vy, vth, goal_th)
                if cmd is not None:
                    return True, cmd, "braking and turning to the goal yaw"
            ok, cmd = self._stop_with_acc_limits(costmap, x, y, yaw, vx, vy, vth)
            if not ok:
                return False, _ZERO, "cannot brake before rotating to the goal yaw: the braking trajectory collides"
            return True, cmd, "braking before rotating to the goal yaw"
        self._rotating_to_goal = True
        ok, cmd = self._rotate_to_goal(costmap, x, y, yaw, vx, vy, vth, goal_th)
        if ok:
            return True, cmd, "rotating to the goal yaw"
        return None if far else (False, _ZERO, "cannot rotate to the goal yaw: the rotation collides")

    def _turn_is_free(self, costmap, x, y, yaw, goal_th, beyond=0.0):
        """Whether the footprint stays clear of lethal cells over the whole turn on the spot from
        ``yaw`` to ``goal_th`` [rad] (the shorter way) and ``beyond`` [rad] past it, checked every
        0.05 rad."""
        diff = angles.diff(goal_th, yaw)
        return self._sweep_is_free(costmap, x, y, yaw, diff + math.copysign(beyond, diff))

    def _sweep_is_free(self, costmap, x, y, yaw, sweep):
        """Whether the robot's body stays clear of lethal cells (and people) over a turn on the spot
        of ``sweep`` [rad] (signed, any size) from ``yaw``, checked every 0.05 rad.

        The body, not the padded footprint: the Create is round, so a turn on the spot sweeps no
        floor its body does not stand on, but the padded footprint's square back corners reach
        0.31 m from its centre (0.22 m each way with footprint_padding 0.06). Beside a wall 0.30 m
        away no turn was free, and in ``bench/nav.py --pairs 30 --seed 1`` the robot, at the end of
        leg 18 in the kitchen facing the wall's end, rocked at +-0.1 m/s for legs 19-30 (all
        ABORTED, oscillating; the rotate recoveries stopped at once too). The body (footprint padded
        by BODY_PADDING, the back corners at 0.24 m) holds the round robot."""
        steps = max(1, math.ceil(abs(sweep) / 0.05))
        yaws = yaw + sweep * np.arange(steps + 1) / steps
        return self._path_is_free(costmap, np.column_stack([np.full_like(yaws, x), np.full_like(yaws, y), yaws]),
                                  self.planner.body)

    def _turn_toward_plan(self, costmap, x, y, yaw, vx, vth, window):
        """``turn_to_plan_angle``: the command (vx, vy, vth) of a turn on the spot toward the plan
        (braking first if the robot is moving), or None: the robot faces the plan (within
        turn_to_plan_angle, or a third of it once turning), no turn is free either way, or the
        robot has not moved TURN_TO_PLAN_AGAIN since the last such turn (the rollouts decide).

        The turn keeps its way until it ends: the shorter one, or the longer one when only that is
        free. (Replanning once a second resets the rollouts' oscillation flags, and a robot in a
        doorway facing away from its plan swung to and fro between arcs the collision monitor
        stopped.) Unless a replan swings the plan round behind the turn so that its way has more
        than a half turn and TURN_TO_PLAN_REVERSE left: then the other way, if it is free (kept,
        a turn of 2.45 rad went on round to 5.85 rad, 5.6 s, in bench/nav.py seed 1). One turn per
        place: where the rollouts steer for the local goal off the plan's next poses (a corner cut),
        the two turned the robot back and forth."""
        p = self.params
        if p.turn_to_plan_angle <= 0.0 or p.holonomic_robot:
            return None
        if (not self._turn_to_plan and self._turned_at is not None
                and math.hypot(x - self._turned_at[0], y - self._turned_at[1]) < TURN_TO_PLAN_AGAIN):
            return None
        tx, ty = plan_lookahead(window, x, y)
        err = angles.diff(math.atan2(ty - y, tx - x), yaw)
        limit = p.turn_to_plan_angle / 3.0 if self._turn_to_plan else p.turn_to_plan_angle
        if math.hypot(tx - x, ty - y) < _AT_GOAL or abs(err) <= limit:
            return self._end_turn_to_plan(x, y)
        ways = (_sign(err), -_sign(err))
        if self._turn_to_plan:
            way = self._turn_to_plan
            left = err if _sign(err) == way else err + way * 2.0 * math.pi
            ways = (-way, way) if abs(left) > math.pi + TURN_TO_PLAN_REVERSE else (way,)
        for way in ways:
            sweep = err if _sign(err) == way else err + way * 2.0 * math.pi  # signed, ``way`` round
            cmd = self._turn_on_the_spot(costmap, x, y, yaw, vx, vth, sweep)
            if cmd is not None:
                self._turn_to_plan = way
                return cmd
        return self._end_turn_to_plan(x, y)

    def _turn_away_from_people(self, costmap, x, y, yaw, vx, vth, window):
        """When the forward motion is refused for people: the command of a turn on the spot toward
        the plan (its pose TURN_TO_PLAN_LOOKAHEAD on) if the plan leads away from every person and
        leg-height return within AWAY_RADIUS (each more than 90 deg off the plan's direction) and the
        robot faces more than AWAY_MIN_TURN off it; else None (the robot stops and waits). Why: a
        resident walked up to the robot standing at its last goal, 0.37 m from its side; the next
        goal lay 0.5 m the other way, but the arcs toward it began by closing in on her, so the robot
        waited, gave way 1 m the wrong way and came back: 16.6 s for a 0.52 m plan (bench/nav.py
        --seed 2, 30 Nov). Facing the plan it leaves her, which min_person_distance allows."""
        if (not self._turning_away and self._turned_away_at is not None
                and math.hypot(x - self._turned_away_at[0], y - self._turned_away_at[1]) < TURN_TO_PLAN_AGAIN):
            return None  # one such turn per place: a robot that arced off and turned back got nowhere
        tx, ty = plan_lookahead(window, x, y)
        ux, uy = tx - x, ty - y
        if math.hypot(ux, uy) < _AT_GOAL:
            return None
        err = angles.diff(math.atan2(uy, ux), yaw)
        if abs(err) <= AWAY_MIN_TURN:
            return None
        near = np.vstack([self.planner.people[:, :2], self.planner.still_people[:, :2]])
        near = near[np.hypot(near[:, 0] - x, near[:, 1] - y) <= AWAY_RADIUS]
        if not len(near) or np.any((near[:, 0] - x) * ux + (near[:, 1] - y) * uy >= 0.0):
            return None
        return self._turn_on_the_spot(costmap, x, y, yaw, vx, vth, err)

    def _end_turn_away(self, x, y):
        """No turn away from people this cycle; one that was under way ended at (x, y)."""
        if self._turning_away:
            self._turning_away, self._turned_away_at = False, (x, y)

    def _end_turn_to_plan(self, x, y):
        """No turn toward the plan (None); one that was under way ended here."""
        if self._turn_to_plan:
            self._turn_to_plan, self._turned_at = 0.0, (x, y)

    def _turn_on_the_spot(self, costmap, x, y, yaw, vx, vth, sweep):
        """One control period of a turn through ``sweep`` [rad] (signed): the translation braked at
        acc_lim_x, the rotation toward min(max_vel_theta, sqrt(2 acc_lim_theta |left|)) within
        acc_lim_theta, at least min_in_place_vel_theta once the robot has stopped; None when the
        braking path or the rest of the turn collides."""
        p = self.params
        way = _sign(sweep)
        vx, vth = self._ramp_from(vx, 0, p.acc_lim_x), self._ramp_from(vth, 2, p.acc_lim_theta)
        cvth = self._turn_rate(vth, sweep)
        cvx = _sign(vx) * max(0.0, abs(vx) - p.acc_lim_x * p.sim_period)
        if cvx == 0.0 and cvth * way < p.min_in_place_vel_theta:
            cvth = way * p.min_in_place_vel_theta  # the base's dead band: as rotateToGoal
        points = self._braking_path(x, y, yaw, cvx, cvth, hold=0.0)
        if not self._path_is_free(costmap, points, self.planner.body if cvx == 0.0 else None):
            return None
        sx, sy, syaw = points[-1]
        if not self._sweep_is_free(costmap, sx, sy, syaw, sweep - angles.diff(syaw, yaw)):
            return None
        return (cvx, 0.0, cvth)

    def _ramp_from(self, measured, index, acc):
        """The velocity an acceleration-limited step starts from: the last command's component
        ``index`` when the odometry ``measured`` is within two steps of it (the base is still
        catching up with it: stepping from odometry would halve the acceleration on a base that
        lags by a cycle), else ``measured``."""
        last = self._last_cmd[index]
        return last if abs(last - measured) <= 2.0 * acc * self.params.sim_period else measured

    def _final_approach(self, costmap, x, y, yaw, vx, vth, window):
        """Florence's final approach (``final_approach_dist``): the command (vx, 0, vth) that drives
        at min(max_vel_x, sqrt(2 acc_lim_x d)) toward the goal d [m] away, steering by pure pursuit
        onto the plan, or None to leave the cycle to the rollouts: the goal is farther, the plan
        bends on the way there (its length > 1.2 d + 0.1 m), the plan is not ahead (> 0.8 rad off the
        heading), or braking to a stop from that command would put the footprint on a lethal cell.

        ROS's rollouts score the goal distance at the end of sim_time, so near the goal the robot
        picks about d / sim_time and creeps the last metre (measured in florence_sim: 2.0 s from
        0.8 m to the 0.25 m tolerance, 1.1 s at max_vel_x)."""
        p = self.params
        goal = window[-1, :2]
        d = math.hypot(goal[0] - x, goal[1] - y)
        if d > p.final_approach_dist:
            return None
        near = int(np.argmin(np.hypot(window[:, 0] - x, window[:, 1] - y)))
        rest = window[near:, :2]
        if float(np.sum(np.hypot(*np.diff(rest, axis=0).T))) > 1.2 * d + 0.1:
            return None
        # pure pursuit: the first plan point at least 0.4 m away (or the goal)
        ahead = np.hypot(rest[:, 0] - x, rest[:, 1] - y) >= min(0.4, d)
        tx, ty = rest[int(np.argmax(ahead))] if ahead.any() else goal
        lookahead = math.hypot(tx - x, ty - y)
        alpha = angles.diff(math.atan2(ty - y, tx - x), yaw)
        if abs(alpha) > 0.8 or lookahead < 1e-6:
            return None
        dt = p.sim_period
        vx, vth = self._ramp_from(vx, 0, p.acc_lim_x), self._ramp_from(vth, 2, p.acc_lim_theta)
        v = max(p.min_vel_x, min(p.max_vel_x, self.planner.speed_cap, math.sqrt(2.0 * p.acc_lim_x * d)))
        v = min(max(v, vx - p.acc_lim_x * dt), vx + p.acc_lim_x * dt)
        w = v * 2.0 * math.sin(alpha) / lookahead
        w = min(max(w, vth - p.acc_lim_theta * dt, p.min_vel_theta), vth + p.acc_lim_theta * dt, p.max_vel_theta)
        points = self._braking_path(x, y, yaw, v, w, hold=dt)
        if not self._path_is_free(costmap, points):
            return None
        self.local_plan = points
        return (v, 0.0, w)

    def _turn_step(self, yaw, vth, goal_th):
        """The turn rate [rad/s] one control period on from ``vth`` toward the braking speed
        min(max_vel_theta, sqrt(2 acc_lim_theta |error|)) to the goal yaw ``goal_th`` [rad]."""
        return self._turn_rate(vth, angles.diff(goal_th, yaw))

    def _turn_rate(self, vth, err):
        """As :meth:`_turn_step` for a turn of ``err`` [rad] still to go (signed, any size)."""
        p = self.params
        dt = p.sim_period
        want = math.copysign(min(p.max_vel_theta, math.sqrt(2.0 * p.acc_lim_theta * abs(err))), err)
        return min(max(want, vth - p.acc_lim_theta * dt), vth + p.acc_lim_theta * dt)

    def _brake_and_turn(self, costmap, x, y, yaw, vx, vy, vth, goal_th):
        """``rotate_while_braking``: slow the translation by acc_lim_x over one control period while
        the rotation speeds up toward the goal yaw (as :meth:`_rotate_to_goal`, without the in-place
        minimum); None when the braking arc or the rest of the turn at its end would collide."""
        p = self.params
        dt = p.sim_period
        vx, vth = self._ramp_from(vx, 0, p.acc_lim_x), self._ramp_from(vth, 2, p.acc_lim_theta)
        cvx = _sign(vx) * max(0.0, abs(vx) - p.acc_lim_x * dt)
        cvy = _sign(vy) * max(0.0, abs(vy) - p.acc_lim_y * dt)
        cvth = self._turn_step(yaw, vth, goal_th)
        if abs(cvy) > 0.0:
            return None  # a holonomic base strafing: ROS's braking, then the turn
        points = self._braking_path(x, y, yaw, cvx, cvth, hold=0.0)
        if not self._path_is_free(costmap, points, self.planner.body if cvx == 0.0 else None):
            return None
        sx, sy, syaw = points[-1]
        overshoot = max(0.0, cvth * cvth / (2.0 * p.acc_lim_theta) - p.yaw_goal_tolerance)
        if not self._turn_is_free(costmap, sx, sy, syaw, goal_th, overshoot):
            return None
        return (cvx, cvy, cvth)

    def _turn_before_tolerance(self, costmap, x, y, yaw, vx, vy, vth, goal):
        """``turn_before_tolerance``: a command that brakes and turns to the goal yaw outside
        xy_goal_tolerance, or None to drive on. :func:`goal_turn_times` simulates braking now at
        ``_EARLY_DECELS`` of acc_lim_x and after driving on straight for whole control periods up
        to the tolerance. The robot starts when an option that starts now stops at least
        ``_EARLY_MARGIN`` inside the tolerance and reaches both tolerances sooner than any later
        one; then, each cycle, it takes the option that still stops inside the tolerance and, of
        those within half a control period of the soonest, stops nearest the goal; it drives on when
        that option's path or the turn at its end is not free."""
        p = self.params
        dt = p.sim_period
        d = math.hypot(goal[0] - x, goal[1] - y)
        speed = abs(self._ramp_from(vx, 0, p.acc_lim_x))
        vth = self._ramp_from(vth, 2, p.acc_lim_theta)
        decels = p.acc_lim_x * np.asarray(_EARLY_DECELS)
        if (abs(vy) > 0.0 or abs(angles.diff(goal[2], yaw)) <= p.yaw_goal_tolerance
                or d > p.xy_goal_tolerance + speed * speed / (2.0 * decels.min())):
            self._turning_early = False
            return None
        periods = max(1, math.ceil((d - p.xy_goal_tolerance) / max(speed, 1e-3) / dt))
        # options: every braking rate (columns) after 0, 1, ..., periods control periods (rows)
        times, ends, poses, stops = goal_turn_times(p, (x, y, yaw), speed, vth, goal,
                                                    dt * np.arange(periods + 1)[:, None], decels)
        k = len(decels)  # the first row starts now
        margin = 0.0 if self._turning_early else _EARLY_MARGIN
        now = np.nonzero(ends[:k] <= p.xy_goal_tolerance - margin)[0]
        later = times[k:][ends[k:] <= p.xy_goal_tolerance - _EARLY_MARGIN].min(initial=math.inf)
        if len(now) == 0 or not (self._turning_early or times[now].min() < later):
            self._turning_early = False
            return None
        # of the options within half a control period of the soonest, the one that stops nearest the goal
        near = now[times[now] <= times[now].min() + 0.5 * dt]
        best = int(near[np.argmin(ends[near])])
        path = poses[:max(1, stops[best]), best]
        sx, sy, syaw = path[-1]
        cvx = _sign(vx) * max(0.0, speed - decels[best] * dt)
        cvth = self._turn_step(yaw, vth, goal[2])
        overshoot = max(0.0, p.max_vel_theta ** 2 / (2.0 * p.acc_lim_theta) - p.yaw_goal_tolerance)
        self._turning_early = (self._path_is_free(costmap, path)
                               and self._turn_is_free(costmap, sx, sy, syaw, goal[2], overshoot))
        if not self._turning_early:
            return None
        self.local_plan = path
        return (cvx, 0.0, cvth)

    def _braking_path(self, x, y, yaw, v, w, hold):
        """Poses (K, 3) of driving at (v [m/s], w [rad/s]) for ``hold`` [s], then braking the
        translation at acc_lim_x to a stop with w held, every sim_granularity [m] (at least 4 steps)."""
        p = self.params
        t_stop = hold + abs(v) / p.acc_lim_x
        length = abs(v) * hold + v * v / (2.0 * p.acc_lim_x)
        steps = max(4, math.ceil(length / p.sim_granularity))
        t = np.linspace(0.0, t_stop, steps + 1)
        h = t[1] - t[0]
        speed = np.where(t < hold, v, _sign(v) * np.maximum(0.0, abs(v) - p.acc_lim_x * (t - hold)))
        th = yaw + w * t
        px = x + np.concatenate([[0.0], np.cumsum(speed[:-1] * np.cos(th[:-1]) * h)])
        py = y + np.concatenate([[0.0], np.cumsum(speed[:-1] * np.sin(th[:-1]) * h)])
        return np.column_stack([px, py, th])

    def _path_is_free(self, costmap, points, footprint=None):
        """Whether ``footprint`` (None: the padded footprint) stays clear of lethal cells at every
        pose (x, y, yaw) of ``points`` and the path does not come nearer than min_person_distance to
        a person (standing where they are) than its first pose (the paths checked here are the
        Florence final approach's and braking turns: they end in a stop)."""
        if not poses_are_free(costmap, points, self.planner.footprint if footprint is None else footprint):
            return False
        people, still = self.planner.people, self.planner.still_people
        if self.params.min_person_distance > 0.0 and (len(people) or len(still)):
            from move_base.people_layer import approaches

            pts = np.asarray(points, dtype=float).reshape(1, -1, 3)
            return not approaches(pts, np.zeros(pts.shape[:2]), people, self.params.min_person_distance,
                                  still=still)[0]
        return True

    def _goal_yaw_verdict(self, angle, vth):
        """"reached", "turn" or "stop" for a robot ``angle`` [rad] short of the goal yaw, turning at
        ``vth`` [rad/s]. ROS: reached when |angle| <= yaw_goal_tolerance, else turn, whatever the
        turn rate. With coast_to_goal_yaw a robot still turning (above rot_stopped_velocity) is
        judged by where a zero command now leaves it (the turn over command_lag and the pose's age,
        then braking at acc_lim_theta, the rate velocity_filter allows): stop (a zero command) when
        that is within half the tolerance short of the goal yaw or anywhere past it (turning on
        only adds to the overshoot), else turn; at rest, ROS's rule: reached within the tolerance,
        else turn again (toward the goal yaw, from whichever side the coasting ended). At 1 rad/s
        (min_in_place_vel_theta) a robot coasts 0.5 rad after a zero command, more than the
        tolerance: ROS's rule left it standing up to 0.56 rad past the goal yaw (test_nav_sim)."""
        p = self.params
        if not p.coast_to_goal_yaw or abs(vth) <= p.rot_stopped_velocity:
            return "reached" if abs(angle) <= p.yaw_goal_tolerance else "turn"
        w = self._ramp_from(vth, 2, p.acc_lim_theta)
        coast = w * (p.command_lag + self.pose_age) + w * abs(w) / (2.0 * p.acc_lim_theta)
        rest = angle - coast  # the error left once the robot stands
        return "stop" if rest * w <= 0.0 or abs(rest) <= 0.5 * p.yaw_goal_tolerance else "turn"

    def _stopped_moving(self, vx, vy):
        """Translation within trans_stopped_velocity (the rotation may go on)."""
        p = self.params
        return abs(vx) <= p.trans_stopped_velocity and abs(vy) <= p.trans_stopped_velocity

    def _stopped(self, vx, vy, vth):
        """base_local_planner::stopped: every velocity within its stopped threshold."""
        p = self.params
        return (abs(vth) <= p.rot_stopped_velocity and abs(vx) <= p.trans_stopped_velocity
                and abs(vy) <= p.trans_stopped_velocity)

    def _stop_with_acc_limits(self, costmap, x, y, yaw, vx, vy, vth):
        """stopWithAccLimits: slow every velocity toward zero by its acceleration limit over one
        control period, if that trajectory is legal; else (False, zero)."""
        p = self.params
        t = p.sim_period
        cvx = _sign(vx) * max(0.0, abs(vx) - p.acc_lim_x * t)
        cvy = _sign(vy) * max(0.0, abs(vy) - p.acc_lim_y * t)
        cvth = _sign(vth) * max(0.0, abs(vth) - p.acc_lim_theta * t)
        if self.planner.check_trajectory(costmap, x, y, yaw, vx, vy, vth, cvx, cvy, cvth):
            return True, (cvx, cvy, cvth)
        return False, _ZERO

    def _rotate_to_goal(self, costmap, x, y, yaw, vx, vy, vth, goal_th):
        """rotateToGoal: turn toward ``goal_th`` [rad] at a speed within [min_in_place_vel_theta,
        max_vel_theta], reachable in one control period, and slow enough to stop at the goal yaw
        (sqrt(2 * acc_lim_theta * |error|)); min_in_place_vel_theta wins over the last two."""
        p = self.params
        ang_diff = angles.diff(goal_th, yaw)
        if ang_diff > 0.0:
            v = min(p.max_vel_theta, max(p.min_in_place_vel_theta, ang_diff))
        else:
            v = max(p.min_vel_theta, min(-p.min_in_place_vel_theta, ang_diff))
        max_acc_vel = abs(vth) + p.acc_lim_theta * p.sim_period
        min_acc_vel = abs(vth) - p.acc_lim_theta * p.sim_period
        v = _sign(v) * min(max(abs(v), min_acc_vel), max_acc_vel)
        max_speed_to_stop = math.sqrt(2.0 * p.acc_lim_theta * abs(ang_diff))
        v = _sign(v) * min(max_speed_to_stop, abs(v))
        if v > 0.0:
            v = min(p.max_vel_theta, max(p.min_in_place_vel_theta, v))
        else:
            v = max(p.min_vel_theta, min(-p.min_in_place_vel_theta, v))
        # Florence: the turn is checked up to the goal yaw and the overshoot of braking from v once
        # the goal is reached. ROS checks sim_time of turning at v, which runs far past the goal yaw,
        # and gave up on goals near walls.
        overshoot = max(0.0, v * v / (2.0 * p.acc_lim_theta) - p.yaw_goal_tolerance)  # after "reached"
        if self._turn_is_free(costmap, x, y, yaw, goal_th, overshoot):
            return True, (0.0, 0.0, v)
        return False, _ZERO
