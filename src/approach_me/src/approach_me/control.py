"""ApproachMe's control (ROS-free): phase 1 drives to the position, phase 2 turns to the heading
(seed 4.3.2), with the person kept by the caller (tracker reports between, odometry throughout).

Frames and units as approach_me.geometry: one fixed frame (odom) [m, rad]; commands (v [m/s],
w [rad/s]), REP 103.

Phase 1 (``drive``): the goal G follows the person (geometry.goal_position along the direction fixed
at goal time); the robot steers (w = k_angular * bearing) to the first waypoint of
geometry.approach_path at least ``lookahead`` away (a spiral about the person that keeps them at one
bearing, in view, and never brings the robot nearer than the goal),
at v = min(max speed, k_linear * distance left, the speed it can stop from at ``decel``) * cos(bearing)
(no driving on while facing away). A goal less than ``max_reverse`` behind the robot on a straight
path is reached backwards. Within ``xy_tolerance`` of G it drives on while it still closes in, to
ARRIVE_SHARE of the tolerance or until G is abeam (:meth:`Approacher._arrived`): phase 2.

Phase 2 (``turn``): w = k_angular * (heading error) toward geometry.final_heading, no faster than
the robot can stop from at ``turn_decel`` and at least ``min_turn_rate``; within ``yaw_tolerance``,
turning no faster than :meth:`Approacher.settled_rate`, the goal is reached. (A robot that came into
position still steering at 1 rad/s with its heading by chance within the tolerance was told to stop
there and coasted 0.7 rad past it: ``make demo`` seed 2, 41 degrees off.) A person who shifts the
goal more than twice ``xy_tolerance`` away sends the robot back to phase 1.
"""

import math
from dataclasses import dataclass

from velocity_filter.limiter import clamp, step_towards

from approach_me import geometry
from florence_common import pose as pose2d
from florence_common.angles import diff
from florence_common.params import Param, ParamTable

DRIVE, TURN, DONE = "drive", "turn", "done"
ARRIVE_SHARE = 0.3  # within ~xy_tolerance, phase 1 ends this near the goal position (or on passing it)

# The gains: dynamic_reconfigure (cfg/ApproachMe.cfg renders this table) and the node's parameters.
GAINS = ParamTable(
    Param("k_linear", float, 1.0, "forward speed per metre left to the goal position", unit="1/s", gt=0, le=5),
    Param("k_angular", float, 2.0, "turn rate per radian of bearing or heading error", unit="1/s", gt=0, le=10),
    Param("decel", float, 0.4, "deceleration planned into the goal position", unit="m/s^2", gt=0, le=1),
    Param("turn_decel", float, 0.5, "angular deceleration planned into the final heading", unit="rad/s^2", gt=0,
          le=3),
    Param("max_lin_acc", float, 0.8, "largest change of the forward speed per second", unit="m/s^2", gt=0, le=3),
    Param("max_ang_acc", float, 1.0, "largest change of the turn rate per second (velocity_filter's limit)",
          unit="rad/s^2", gt=0, le=10),
    Param("lookahead", float, 0.3, "how far ahead on the way the robot steers to", unit="m", gt=0, le=2),
    Param("min_turn_rate", float, 0.15, "least turn rate of phase 2 (so that it ends)", unit="rad/s", ge=0, le=1),
    Param("max_reverse", float, 0.5, "a goal position at most this far behind the robot is reached backwards",
          unit="m", ge=0, le=1.5),
)


@dataclass
class Request:
    """A goal after defaults and checks: distance [m], p2r and r2p [rad], speeds [m/s, rad/s]."""

    distance: float
    p2r: float
    r2p: float
    max_lin_speed: float
    max_ang_speed: float


@dataclass
class Step:
    v: float
    w: float
    phase: str
    goal: tuple  # (x, y, yaw) the robot aims at, fixed frame
    position_error: float  # [m]
    heading_error: float  # [rad] (phase 2; 0 before)
    text: str


class Approacher:
    """The controller of one goal: ``person0`` and ``robot0`` (x, y) at goal time fix the approach
    direction."""

    def __init__(self, gains, request, person0, robot0, rate, xy_tolerance=0.05, yaw_tolerance=0.05):
        self.gains = gains
        self.request = request
        self.dt = 1.0 / rate
        self.xy_tolerance = xy_tolerance
        self.yaw_tolerance = yaw_tolerance
        self.direction = geometry.approach_direction(person0, robot0, request.p2r)
        self.turn_sign = math.copysign(1.0, request.p2r) if request.p2r else 0.0
        self.phase = DRIVE
        self.v = self.w = 0.0
        self._last_err = None  # [m] the position error of the last cycle

    def goal(self, person):
        """(x, y) of the goal position for the person at ``person`` (x, y)."""
        return geometry.goal_position(person, self.direction, self.request.distance)

    def _command(self, v, w):
        g, r = self.gains, self.request
        self.v = step_towards(self.v, clamp(v, r.max_lin_speed), g.max_lin_acc * self.dt)
        self.w = step_towards(self.w, clamp(w, r.max_ang_speed), g.max_ang_acc * self.dt)
        return self.v, self.w

    def step(self, robot, person):
        """One cycle: ``robot`` (x, y, yaw) and ``person`` (x, y) in the fixed frame."""
        g, r = self.gains, self.request
        gx, gy = self.goal(person)
        err = math.hypot(gx - robot[0], gy - robot[1])
        if self.phase == TURN and err > 2.0 * self.xy_tolerance:
            self.phase = DRIVE  # the person moved: drive again
        if self.phase == DRIVE and err <= self.xy_tolerance and self._arrived(robot, (gx, gy), err):
            self.phase = TURN
        self._last_err = err
        yaw = geometry.final_heading(robot[:2], person, r.r2p)
        if self.phase == DRIVE:
            return self._drive(robot, person, (gx, gy), err, yaw)
        heading_error = diff(yaw, robot[2])
        if abs(heading_error) <= self.yaw_tolerance and abs(self.w) <= self.settled_rate():
            self.phase = DONE
            v, w = self._command(0.0, 0.0)
            return Step(v, w, DONE, (gx, gy, yaw), err, heading_error, "reached")
        rate = min(g.k_angular * abs(heading_error), math.sqrt(2.0 * g.turn_decel * abs(heading_error)))
        w = math.copysign(max(rate, g.min_turn_rate), heading_error)
        v, w = self._command(0.0, w)
        return Step(v, w, TURN, (gx, gy, yaw), err, heading_error, f"turning: {heading_error:+.2f} rad to go")

    def _arrived(self, robot, goal, err):
        """Within ``xy_tolerance``, phase 1 goes on while the robot still closes in: it ends within
        ARRIVE_SHARE of the tolerance, once the goal is abeam or behind the robot, or when the error stops
        shrinking (ending on entering the tolerance, the robot stopped 0.011-0.067 m short of the goal,
        along the line from the person, in every run of bench/enablers.py)."""
        ahead = pose2d.transform_points(pose2d.inverse(robot), [goal])[0][0]
        return (err <= ARRIVE_SHARE * self.xy_tolerance or ahead <= 0.0
                or (self._last_err is not None and err >= self._last_err))

    def settled_rate(self):
        """The fastest turn [rad/s] at which phase 2 may end: the rate phase 2 itself turns at within
        ``yaw_tolerance`` (its deceleration law there, or ``min_turn_rate``). A robot stopped from it
        at ``max_ang_acc`` turns on by at most half the tolerance (0.025 rad with the defaults)."""
        g = self.gains
        return max(g.min_turn_rate, min(math.sqrt(2.0 * g.turn_decel * self.yaw_tolerance),
                                        math.sqrt(g.max_ang_acc * self.yaw_tolerance)))

    def _drive(self, robot, person, goal, err, yaw):
        g, r = self.gains, self.request
        tx, ty = pose2d.transform_points(pose2d.inverse(robot), [goal])[0]
        if abs(math.atan2(ty, tx)) > 2.0 * math.pi / 3.0 and err <= g.max_reverse:  # just behind: reverse to it
            speed = min(r.max_lin_speed, g.k_linear * err, math.sqrt(2.0 * g.decel * err))
            back = diff(math.atan2(ty, tx), math.pi)
            v, w = self._command(-speed * max(0.0, math.cos(back)), g.k_angular * back)
            return Step(v, w, DRIVE, (goal[0], goal[1], yaw), err, 0.0, f"backing to the goal position, {err:.2f} m")
        path = geometry.approach_path(robot[:2], person, goal, self.turn_sign)
        target = next((p for p in path if math.hypot(p[0] - robot[0], p[1] - robot[1]) >= g.lookahead), path[-1])
        tx, ty = pose2d.transform_points(pose2d.inverse(robot), [target])[0]
        bearing = math.atan2(ty, tx)
        left = sum(math.dist(a, b) for a, b in zip([robot[:2], *path[:-1]], path, strict=True))
        speed = min(r.max_lin_speed, g.k_linear * left, math.sqrt(2.0 * g.decel * left))
        v, w = self._command(speed * max(0.0, math.cos(bearing)), g.k_angular * bearing)
        return Step(v, w, DRIVE, (goal[0], goal[1], yaw), err, 0.0, f"driving to the goal position, {left:.2f} m")

    def stop(self):
        self.v = self.w = 0.0
