"""move_base's state machine (ROS-free): plan, control, clear, with ROS's patience rules.

One :meth:`MoveBaseCore.cycle` call is one turn of ROS move_base's ``executeCycle`` at
``controller_frequency``. Planning runs inside the cycle (the plan takes milliseconds here, so
no planner thread is needed; ``planner_frequency`` > 0 replans while controlling, as ROS does).

States (ROS names): PLANNING -> CONTROLLING -> goal reached; a failure goes to CLEARING, which runs
the next recovery behaviour and goes back to PLANNING; when the recoveries are used up the goal
is aborted. Unlike ROS every abort says why (the planner's or controller's last reason), a goal
that can never be reached on the static map (off the map, inside a wall) is aborted at once, and
recoveries are stepped by the cycle so that a cancel stops even an in-place rotation.

The collaborators are injected (duck-typed), so the machine is tested with fakes:
    planner(start, goal) -> PlanResult-like (ok, poses (N, 3), reason, permanent: bool)
    controller: set_plan(poses, giving_way=False), compute_velocity(pose) -> (ok, (vx, vy, vth),
                reason), is_goal_reached() -> bool
    recoveries: objects with ``name`` and ``start(now, pose)``, ``step(now, pose) -> (done, cmd)``
    sensors_current() -> (ok, reason)
    people (optional): blocking(pose, goal, reason, waiting=False) -> why people stand in the way
        after a failed plan (reason None) or control (the controller's reason), or '' (``waiting``:
        the robot already waits for them); clear(pose, poses) -> whether
        nobody stands close in front along the plan ``poses``; give_way(pose) -> a pose (x, y, yaw)
        out of their way, or None; plan_to(start, pose) -> PlanResult-like.

Florence's WAITING state (``person_wait_timeout`` > 0): a plan or a control that fails because
people stand in the way (``people.blocking``) makes the robot stand and replan every cycle
instead of counting toward the planner's or controller's patience; it goes on (CONTROLLING) as
soon as a plan and a valid command exist again and nobody stands close in front (``people.clear``:
a way round a person close in front would creep past them). After ``give_way_after`` it drives to
``people.give_way`` (a place out of the people's way: a person may be waiting for the robot) and
waits there; a give-way move that comes no ``GIVE_WAY_PROGRESS`` nearer its place for
``GIVE_WAY_PATIENCE`` ends there and then (beside a door jamb a robot stood 35 s in a give-way
move, its controller's commands valid but the robot not moving, while the person it waited for
walked off and back). After
``person_wait_timeout`` without a valid command the usual recoveries run, and the goal is not
waited for again until the robot moves on.
"""

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from florence_common import angles
from florence_common.params import Param, ParamTable

log = logging.getLogger(__name__)
# a give-way move that comes no GIVE_WAY_PROGRESS [m] nearer its place for GIVE_WAY_PATIENCE [s] ends
GIVE_WAY_PROGRESS = 0.1
GIVE_WAY_PATIENCE = 5.0

PLANNING = "PLANNING"
CONTROLLING = "CONTROLLING"
CLEARING = "CLEARING"
WAITING = "WAITING"  # Florence: people stand in the way; the robot waits (or gives way)

PLANNING_R = "PLANNING_R"
CONTROLLING_R = "CONTROLLING_R"
OSCILLATION_R = "OSCILLATION_R"

ZERO = (0.0, 0.0, 0.0)
TURN_BEFORE_PEOPLE = "only a turn on the spot, the plan ahead, with a person close in front"


PARAMS = ParamTable(
    Param("planner_frequency", float, 0.0, "replanning rate while controlling (0: plan on a new goal and after "
          "failures only)", unit="Hz", ge=0.0),
    Param("replan_keep_ratio", float, 0.0, "Florence: when replanning while controlling finds a plan that goes "
          "another way (more than 1 m from the plan being followed somewhere), the plan being followed is kept "
          "while its rest costs at most this fraction more than the new one (plus replan_keep_margin), so that "
          "the robot does not swap back and forth between two ways round a loop of rooms; never within 1.5 m "
          "of a person or of leg-height returns the maps do not explain (0 with "
          "replan_keep_margin 0: every new plan is taken, ROS)", ge=0.0),
    Param("replan_keep_margin", float, 0.0, "Florence: the extra cost a kept plan may have, as metres of free "
          "floor (see replan_keep_ratio)", unit="m", ge=0.0),
    Param("planner_patience", float, 5.0, "time without a valid plan before the recoveries run", unit="s", ge=0.0),
    Param("controller_frequency", float, 20.0, "control loop and velocity command rate", unit="Hz", gt=0.0),
    Param("controller_patience", float, 15.0, "time without a valid command before the recoveries run", unit="s",
          ge=0.0),
    Param("max_planning_retries", int, -1, "failed plans before the recoveries run (-1: planner_patience only)",
          ge=-1),
    Param("oscillation_timeout", float, 0.0, "time allowed without moving oscillation_distance (0: no limit)",
          unit="s", ge=0.0),
    Param("oscillation_distance", float, 0.5, "how far the robot must move to reset the oscillation clock",
          unit="m", ge=0.0),
    Param("recovery_behavior_enabled", bool, True, "run the recovery behaviours on a failure"),
    Param("clearing_rotation_allowed", bool, True, "the default recoveries include the rotations"),
    Param("conservative_reset_dist", float, 3.0, "side of the square the default conservative reset keeps",
          unit="m", ge=0.0),
    Param("shutdown_costmaps", bool, False, "pause the costmaps while there is no goal"),
    # Florence addition (-1 = ROS: no limit). A robot shuffling on the spot in a doorway restarted
    # the recovery list for ever in ROS.
    Param("max_recovery_restarts", int, -1, "Florence: how often the recovery list may start over from its first "
          "entry after progress (moved oscillation_distance; a plan or a command found again counts once the "
          "robot moved oscillation_distance since the last recovery began) before the goal is aborted "
          "(-1: no limit, ROS)", ge=-1),
    Param("person_wait_timeout", float, 0.0, "Florence: when people stand in the way (no plan, but one on the "
          "maps alone; or no trajectory that keeps min_person_distance), wait this long for them, replanning "
          "every cycle, before the recoveries run; the robot goes on as soon as the way is free, and the waits "
          "add up until it comes oscillation_distance nearer the goal (0: no waiting, ROS)", unit="s", ge=0.0),
    Param("give_way_after", float, 0.0, "Florence: while waiting, after this long move to the nearest place out of "
          "the way of the people who block it, then wait there (a person may be waiting for the robot to "
          "leave their way; 0: never)", unit="s", ge=0.0),
)
"""move_base's own parameters (``~``: ROS's names and defaults)."""


def core_params(**values):
    """:data:`PARAMS` from keyword values, the others at their defaults (ParamError naming a bad one)."""
    return PARAMS.validate(values)


@dataclass
class CycleResult:
    """What one cycle asks of the node: a velocity command (or None: send nothing new) and,
    when the goal ended, its outcome ("succeeded" or "aborted") with the reason text."""

    cmd: tuple | None = None
    outcome: str | None = None
    text: str = ""
    new_plan: object = None
    started_recovery: str | None = None


@dataclass
class _GoalState:
    goal: tuple
    state: str = PLANNING
    trigger: str = PLANNING_R
    recovery_index: int = 0
    recovery: object = None
    last_valid_plan: float = 0.0
    last_valid_control: float = 0.0
    # [s] the last WAITING cycle with a pose and current sensors: standing for people counts as
    # control for controller_patience's transform and sensor checks
    last_seen_waiting: float = 0.0
    last_oscillation_reset: float = 0.0
    last_cycle: float | None = None  # [s] the previous cycle's time
    oscillation_pose: tuple = (0.0, 0.0)
    planning_retries: int = 0
    recovery_restarts: int = 0
    recovery_pose: tuple = (math.nan, math.nan)  # where the last recovery began
    last_plan_time: float = -math.inf
    have_plan: bool = False
    plan_poses: object = None  # the plan to the goal the controller follows
    reasons: dict = field(default_factory=dict)
    wait_since: float | None = None  # [s] when this wait began, less the time waited before it (None: not waiting)
    waited: float = 0.0  # [s] waited for people since the last progress, before this wait
    wait_goal_distance: float | None = None  # [m] from the goal when the robot first waited since the last progress
    waited_out: bool = False  # waited person_wait_timeout since the last progress
    giving_way: tuple | None = None  # the pose the robot drives to, out of the people's way
    give_way_best: float = math.inf  # [m] the least distance to it so far ...
    give_way_since: float = 0.0  # [s] ... reached (by GIVE_WAY_PROGRESS or more) then
    gave_way: int = 0  # give-way moves in this wait
    wait_trigger: str = PLANNING_R
    wait_text: str = ""  # why the robot waited, once it waited person_wait_timeout out


def _goes_on(cmd, pose, poses, ahead=0.5, turn=1.0):
    """Whether a command found while waiting for people goes on toward the goal: it drives
    forward, or the plan starts more than ``turn`` [rad] off the robot's heading (the robot must
    turn first). A turn on the spot with the plan ahead, toward the people, would only take the
    people out of the sensors' view."""
    if cmd[0] > 0.01:
        return True
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    d = np.hypot(poses[:, 0] - pose[0], poses[:, 1] - pose[1])
    far = np.nonzero(d >= ahead)[0]
    if len(far) == 0:
        return True  # at the goal: turning to its yaw
    tx, ty = poses[far[0], :2]
    return abs(angles.diff(math.atan2(ty - pose[1], tx - pose[0]), pose[2])) > turn


class MoveBaseCore:
    """The goal-level state machine of move_base; ``params``: :data:`PARAMS`' values
    (``core_params(...)`` or the node's ``read_params(PARAMS)``)."""

    def __init__(self, params, planner, controller, recoveries, sensors_current=None, people=None):
        self.params = params
        self.planner = planner
        self.controller = controller
        self.recoveries = list(recoveries)
        self.sensors_current = sensors_current or (lambda: (True, ""))
        self.people = people
        self.g = None

    # --- goal life cycle ----------------------------------------------------------------------
    @property
    def active(self):
        return self.g is not None

    @property
    def state(self):
        return None if self.g is None else self.g.state

    def set_goal(self, goal, now, pose):
        """Start on a new goal (x, y, yaw) in the global frame; replaces any current goal."""
        self.g = _GoalState(goal=tuple(goal))
        self.g.last_valid_plan = self.g.last_valid_control = self.g.last_oscillation_reset = now
        self.g.oscillation_pose = (pose[0], pose[1]) if pose is not None else (math.nan, math.nan)

    def reset(self):
        """Forget the goal (cancel, preemption, or after an outcome). The node stops the robot."""
        self.g = None

    # --- one cycle ----------------------------------------------------------------------------
    def cycle(self, now, pose):  # noqa: PLR0911 - one exit per state, like ROS executeCycle
        """One control cycle at time ``now`` [s] with the robot at ``pose`` (x, y, yaw) in the global
        frame (None when tf could not tell)."""
        g = self.g
        if g is None:
            return CycleResult()
        p = self.params
        since, g.last_cycle = (now - g.last_cycle if g.last_cycle is not None else 0.0), now
        ok, why = self.sensors_current()
        if pose is None or (not ok and g.state != CLEARING):
            # blind: standing for tf or the sensors is not oscillating, and stops the oscillation clock
            # (Florence; in ROS it runs on, and a robot that stood oscillation_timeout for its sensors
            # goes into its recoveries the moment it can plan again)
            g.last_oscillation_reset += since
        if pose is None:
            # tf could not place the robot: stop; the goal ends when controller_patience runs out
            g.reasons[CONTROLLING_R] = "transform timeout: no pose of the robot in the global frame"
            if now - max(g.last_valid_control, g.last_seen_waiting) > p.controller_patience:
                return self._abort(f"Transform timeout: no robot pose for longer than controller_patience "
                                   f"({p.controller_patience:.1f} s)")
            return CycleResult(cmd=ZERO, text=g.reasons[CONTROLLING_R])

        # oscillation: moving oscillation_distance resets the clock (and the recoveries it started)
        if math.hypot(pose[0] - g.oscillation_pose[0], pose[1] - g.oscillation_pose[1]) >= p.oscillation_distance or (
            math.isnan(g.oscillation_pose[0])
        ):
            g.last_oscillation_reset = now
            g.oscillation_pose = (pose[0], pose[1])
            if g.trigger == OSCILLATION_R:
                self._restart_recoveries(g)

        if not ok and g.state != CLEARING:
            # ROS stops and waits for fresh data; the goal ends when controller_patience runs out.
            g.reasons[CONTROLLING_R] = f"sensor data is out of date: {why}"
            if now - max(g.last_valid_control, g.last_seen_waiting) > p.controller_patience:
                return self._abort(f"Sensor data is out of date for longer than controller_patience "
                                   f"({p.controller_patience:.1f} s): {why}")
            return CycleResult(cmd=ZERO, text=g.reasons[CONTROLLING_R])

        self._progress(pose)
        if g.state == WAITING:
            g.last_seen_waiting = now
            g.last_oscillation_reset = now  # standing for people is not oscillating
            g.oscillation_pose = (pose[0], pose[1])
            return self._wait(now, pose)

        result = CycleResult()
        if g.state == PLANNING or (
            g.state == CONTROLLING and p.planner_frequency > 0.0 and now - g.last_plan_time >= 1.0 / p.planner_frequency
        ):
            planned = self._plan(now, pose)
            if planned is not None:
                return planned
            result.new_plan, self._fresh_plan = self._fresh_plan, None

        if g.state == CONTROLLING:
            return self._control(now, pose, result)
        if g.state == CLEARING:
            return self._clear(now, pose)
        return result

    # --- the three states ---------------------------------------------------------------------
    _fresh_plan = None

    def _plan(self, now, pose):
        """Plan from ``pose`` to the goal; None when the plan is fine, else a result to return."""
        g, p = self.g, self.params
        g.last_plan_time = now
        plan = self.planner(tuple(pose), g.goal)
        if plan.ok:
            self._fresh_plan = plan
            g.last_valid_plan = now
            g.planning_retries = 0
            self.controller.set_plan(plan.poses)
            g.have_plan, g.plan_poses = True, plan.poses
            if g.state == PLANNING:
                g.state = CONTROLLING
                if g.trigger == PLANNING_R:
                    self._restart_recoveries(g, pose)
            return None
        g.reasons[PLANNING_R] = plan.reason
        if getattr(plan, "permanent", False):
            return self._abort(plan.reason)
        if g.state == PLANNING:
            waiting = self._maybe_wait(now, pose, None, PLANNING_R)
            if waiting is not None:
                return waiting
            g.planning_retries += 1
            too_long = now - g.last_valid_plan > p.planner_patience
            too_many = 0 <= p.max_planning_retries < g.planning_retries
            if too_long or too_many:
                log.info("planning failed for %.1f s (%d tries): %s", now - g.last_valid_plan, g.planning_retries,
                         plan.reason)
                g.state = CLEARING
                g.trigger = PLANNING_R
                return CycleResult(cmd=ZERO, text=plan.reason)
            return CycleResult(cmd=ZERO, text=plan.reason)
        # replanning while controlling failed: keep following the old plan (ROS does the same)
        return None

    def _control(self, now, pose, result):
        g, p = self.g, self.params
        if self.controller.is_goal_reached():
            self.reset()
            return CycleResult(cmd=ZERO, outcome="succeeded", text="Goal reached.")
        if p.oscillation_timeout > 0.0 and now - g.last_oscillation_reset > p.oscillation_timeout:
            g.state = CLEARING
            g.trigger = OSCILLATION_R
            g.reasons[OSCILLATION_R] = (f"the robot moved less than oscillation_distance "
                                        f"({p.oscillation_distance:.2f} m) in oscillation_timeout "
                                        f"({p.oscillation_timeout:.1f} s)")
            return CycleResult(cmd=ZERO, text=g.reasons[OSCILLATION_R])
        ok, cmd, reason = self.controller.compute_velocity(tuple(pose))
        if ok and self._turning_before_people(pose, cmd):
            # the controller's only way is a turn on the spot with the plan ahead and a person
            # close in front: stand and wait for them as when it has no way at all (nav bench seed
            # 1, 1 Dec: with Alice waiting 0.52 m in front the robot turned a full turn on the spot
            # in 8 s before it waited; why the local planner chose those turns was not looked into)
            waiting = self._maybe_wait(now, pose, TURN_BEFORE_PEOPLE, CONTROLLING_R)
            if waiting is not None:
                return waiting
        if ok:
            g.last_valid_control = now
            self._leave_wait(now)
            if g.trigger == CONTROLLING_R:
                self._restart_recoveries(g, pose)
            result.cmd = tuple(cmd)
            return result
        g.reasons[CONTROLLING_R] = reason
        waiting = self._maybe_wait(now, pose, reason, CONTROLLING_R)
        if waiting is not None:
            return waiting
        if now - g.last_valid_control > p.controller_patience:
            g.state = CLEARING
            g.trigger = CONTROLLING_R
        else:
            # no valid command now: plan again from here (ROS goes back to PLANNING)
            g.state = PLANNING
        result.cmd = ZERO
        result.text = reason
        return result

    def _clear(self, now, pose):
        g, p = self.g, self.params
        if g.recovery is None:
            if not (p.recovery_behavior_enabled and g.recovery_index < len(self.recoveries)):
                return self._abort(self._final_text())
            if 0 <= p.max_recovery_restarts < g.recovery_restarts:
                return self._abort(f"{self._final_text()} (the recovery behaviours started over "
                                   f"{g.recovery_restarts} times: max_recovery_restarts {p.max_recovery_restarts})")
            g.recovery = self.recoveries[g.recovery_index]
            g.recovery_pose = (pose[0], pose[1])
            log.info("running recovery behaviour %d: %s", g.recovery_index, g.recovery.name)
            g.recovery.start(now, tuple(pose))
            started = g.recovery.name
        else:
            started = None
        name = g.recovery.name
        done, cmd = g.recovery.step(now, tuple(pose))
        if not done:
            return CycleResult(cmd=tuple(cmd) if cmd is not None else ZERO, text=f"recovery {name}",
                               started_recovery=started)
        outcome = getattr(g.recovery, "outcome", "")  # the node logs how it ended
        g.recovery = None
        g.recovery_index += 1
        g.last_oscillation_reset = now
        g.state = PLANNING
        g.planning_retries = 0
        g.last_valid_plan = now
        return CycleResult(cmd=ZERO, text=f"recovery {name} done" + (f": {outcome}" if outcome else ""),
                           started_recovery=started)

    # --- waiting for people (Florence) -----------------------------------------------------
    def _turning_before_people(self, pose, cmd):
        """Whether ``cmd`` only turns on the spot (:func:`_goes_on`: not toward a plan that starts
        more than 1 rad off the heading) while a person stands close in front along the plan (the
        people's ``clear``): what WAITING does not go on with either."""
        g, p = self.g, self.params
        if self.people is None or p.person_wait_timeout <= 0.0 or g.waited_out or g.plan_poses is None:
            return False
        return not _goes_on(cmd, pose, g.plan_poses) and not self.people.clear(tuple(pose), g.plan_poses)

    def _maybe_wait(self, now, pose, reason, trigger):
        """WAITING when people stand in the way of this failed plan (``reason`` None) or control
        (the controller's ``reason``) and the goal has not been waited for since the last valid
        command; else None (ROS's handling goes on)."""
        g, p = self.g, self.params
        if self.people is None or p.person_wait_timeout <= 0.0 or g.waited_out:
            return None
        why = self.people.blocking(tuple(pose), g.goal, reason)
        if not why:
            return None
        if g.wait_since is None:
            # waiting goes on from what was waited since the last progress: a robot that flips
            # between "the way is free" and "blocked" in front of the same person times out all the same
            g.wait_since = now - g.waited
            if g.wait_goal_distance is None:
                g.wait_goal_distance = math.hypot(g.goal[0] - pose[0], g.goal[1] - pose[1])
            log.info("waiting for people: %s", why)
        g.state = WAITING
        g.wait_trigger = trigger
        g.reasons[trigger] = why
        g.giving_way = None
        return CycleResult(cmd=ZERO, text=f"waiting: {why}")

    def _wait(self, now, pose):
        """One cycle of WAITING: give way while a give-way move runs; else plan to the goal and
        try the controller, going on (CONTROLLING) with the first valid command; back to ROS's
        handling when no people block any more; to the recoveries after person_wait_timeout."""
        g, p = self.g, self.params
        waited = now - g.wait_since
        if waited > p.person_wait_timeout:
            g.waited_out = True
            g.giving_way = None
            g.state = CLEARING
            g.trigger = g.wait_trigger
            g.reasons[g.trigger] = g.wait_text = (f"people stood in the way for {waited:.0f} s (person_wait_timeout "
                                                  f"{p.person_wait_timeout:.0f} s): "
                                                  f"{g.reasons.get(g.wait_trigger, '')}")
            return CycleResult(cmd=ZERO, text=g.reasons[g.trigger])
        if g.giving_way is not None:
            ok, cmd, reason = self.controller.compute_velocity(tuple(pose))
            left = math.hypot(g.giving_way[0] - pose[0], g.giving_way[1] - pose[1])
            if left <= g.give_way_best - GIVE_WAY_PROGRESS:
                g.give_way_best, g.give_way_since = left, now
            stuck = now - g.give_way_since > GIVE_WAY_PATIENCE
            if ok and not self.controller.is_goal_reached() and not stuck:
                return CycleResult(cmd=tuple(cmd), text="giving way to people")
            if not ok:
                why = reason
            elif stuck:
                why = f"no {GIVE_WAY_PROGRESS:.2f} m nearer its place ({left:.2f} m away) in {GIVE_WAY_PATIENCE:.0f} s"
            else:
                why = "arrived"
            log.info("gave way: %s", why)
            g.giving_way = None
        # the goal again, every cycle while standing: go on with the first valid command
        plan = self.planner(tuple(pose), g.goal)
        g.last_plan_time = now
        reason = None
        if plan.ok:
            g.have_plan, g.plan_poses = True, plan.poses
            self.controller.set_plan(plan.poses)
            ok, cmd, reason = self.controller.compute_velocity(tuple(pose))
            if ok and not _goes_on(cmd, pose, plan.poses):
                ok, reason = False, "only a turn on the spot toward the people"
            if ok and not self.people.clear(tuple(pose), plan.poses):
                # a way round a person close in front is no way on: it would creep past them
                ok, reason = False, "a person is close in front"
            if ok:
                g.planning_retries = 0
                g.last_valid_plan = g.last_valid_control = g.last_oscillation_reset = now
                self._leave_wait(now)
                g.state = CONTROLLING
                log.info("the way is free after %.1f s: going on", waited)
                return CycleResult(cmd=tuple(cmd), new_plan=plan, text="the way is free: going on")
        why = self.people.blocking(tuple(pose), g.goal, reason, waiting=True)
        if not why:  # stuck, but not for people any more: ROS's patience from now
            log.info("waiting ends after %.1f s: no people in the way any more (%s)", waited,
                     reason or plan.reason)
            g.state = CONTROLLING if plan.ok else PLANNING
            g.last_valid_plan = g.last_valid_control = now
            self._leave_wait(now)
            return CycleResult(cmd=ZERO, text=reason or plan.reason)
        g.reasons[g.wait_trigger] = why
        if p.give_way_after > 0.0 and waited >= p.give_way_after * (g.gave_way + 1) and g.gave_way < 3:
            g.gave_way += 1
            target = self.people.give_way(tuple(pose))
            if target is not None:
                aside = self.people.plan_to(tuple(pose), target)
                if aside.ok:
                    self.controller.set_plan(aside.poses, giving_way=True)
                    g.giving_way = tuple(target)
                    g.give_way_best, g.give_way_since = math.inf, now
                    log.info("giving way: to (%.2f, %.2f)", target[0], target[1])
                    return CycleResult(cmd=ZERO, text="giving way to people")
        return CycleResult(cmd=ZERO, text=f"waiting: {why}")

    def _leave_wait(self, now):
        """Out of WAITING (or past a cycle without waiting): keep the time waited until progress."""
        g = self.g
        if g.wait_since is not None:
            g.waited = now - g.wait_since
            g.wait_since = None

    def _progress(self, pose):
        """The robot came oscillation_distance nearer the goal than where it first waited for people:
        the next wait starts from zero (and may run person_wait_timeout again)."""
        g = self.g
        if g.wait_goal_distance is None or g.wait_since is not None:
            return
        to_goal = math.hypot(g.goal[0] - pose[0], g.goal[1] - pose[1])
        if to_goal <= g.wait_goal_distance - self.params.oscillation_distance:
            g.waited, g.wait_goal_distance, g.waited_out, g.gave_way = 0.0, None, False, 0

    def _restart_recoveries(self, g, pose=None):
        """Progress: the next failure starts the recovery list from its first entry. A plan or a
        command found again (``pose`` given) counts only once the robot has moved oscillation_distance
        from where the last recovery began (Florence; ROS restarts at once): a plan found through a
        freshly cleared costmap that leads nowhere restarted conservative_reset again and again, so
        the rotations, which let the sensors see round the robot, never ran."""
        if g.recovery_index == 0:
            return
        if pose is not None and math.hypot(pose[0] - g.recovery_pose[0], pose[1] - g.recovery_pose[1]) < \
                self.params.oscillation_distance:
            return
        g.recovery_restarts += 1
        g.recovery_index = 0

    def _final_text(self):
        g = self.g
        what = {
            PLANNING_R: "Failed to find a valid plan",
            CONTROLLING_R: "Failed to find a valid control",
            OSCILLATION_R: "Robot is oscillating",
        }[g.trigger]
        after = "even after executing recovery behaviors" if self.params.recovery_behavior_enabled and \
            self.recoveries else "(recovery behaviours disabled)"
        detail = g.reasons.get(g.trigger, "")
        if g.wait_text and g.wait_text not in detail:
            detail = f"{detail} (before that, {g.wait_text})" if detail else g.wait_text
        return f"{what} {after}: {detail}" if detail else f"{what} {after}."

    def _abort(self, text):
        self.reset()
        return CycleResult(cmd=ZERO, outcome="aborted", text=text)

    def stop_recovery(self):
        """Cancel: end a running recovery (its step is not called again)."""
        if self.g is not None:
            self.g.recovery = None
