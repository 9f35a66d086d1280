"""FollowMe's control (ROS-free): the seed's spring law on the person's trail, and the search for a
person lost (seed 4.1.2, 4.1.3).

Frames and units: positions in one fixed frame (the tracker's, odom) [m], the robot's pose
(x, y, yaw) [m, rad] in it, times [s]; commands (v [m/s], w [rad/s]), REP 103 (w > 0 turns left).

The law (seed 4.1.2, with REP 103 signs):

    v = k_distance (d - d*) + k_feedforward * (the person's speed away from the robot)
    w = k_bearing * theta

d is the distance to the person (with ``path_following``, along their trail where it bends: round a
corner the robot comes on to where it sees them again; :meth:`Follower._gap`), d* the desired
following distance, theta the bearing of the point the robot steers to. The seed steered straight at
the person; with ``path_following`` the robot steers along the person's trail instead (pure pursuit
``lookahead`` m ahead on it, farther at speed: :meth:`Follower._lookahead`), so that it goes through a
doorway where the person went rather than across the wall's end; in the open, the trail and the
straight line are one. v is scaled by cos(theta) (no driving on while facing away; turn first),
clamped to the goal's limits, and both are limited by the acceleration limits; w is also capped to what
stops the turn where theta comes to 0 (``brake_turns``: velocity_filter slews the turn rate at 1 rad/s^2 and
commands arrive ``turn_latency`` late; unbraked, the robot overshot its heading). The feed-forward term
(0 gives the seed's pure spring) removes the spring's lag behind a walking person (0.5 m behind at
0.5 m/s with k_distance 1).

A person unseen for ``lost_grace`` s is searched for: the robot turns toward where they were last
seen, drives there along their trail (unless held up for SEARCH_PATIENCE s), then
turns toward where they were heading and on, slowly, looking; after ``lost_timeout`` s unseen the
goal ends (:attr:`Follower.lost`).
"""

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from collision_monitor.monitor import braking_speed
from velocity_filter.limiter import clamp, step_towards

from florence_common import pose as pose2d
from florence_common.angles import diff
from florence_common.params import Param, ParamTable

FOLLOWING, SEARCHING = "following", "searching"
SEARCH_PATIENCE = 2.0  # [s] a search held up this long on its way to where the person was seen looks from there
SEARCH_PROGRESS = 0.05  # [m] the robot moving this far counts as not held up
STILL_SPEED = 0.2  # [m/s] a person last seen slower than this was standing (or sitting) still
SEARCH_LOOKAHEAD = 0.35  # [m] on the trail while searching: through the doorway they took, not across its jamb
CORNER_SPACING = 0.3  # [m] between the trail's points measured for the distance along it (a jittery track's
# 0.1 m steps would add length of their own)
NEAR_SHARE = 0.6  # the distance along the trail counts only beyond this share of the desired distance, straight:
# the robot that comes on round a corner stops at 0.8 of the desired distance straight at the nearest

# The gains: dynamic_reconfigure (cfg/FollowMe.cfg renders this table) and the node's parameters.
GAINS = ParamTable(
    Param("k_distance", float, 1.2, "forward speed per metre the person is farther than the desired distance (the "
          "seed's k_v)", unit="1/s", ge=0, le=5),
    Param("k_bearing", float, 2.0, "turn rate per radian of bearing of the point steered to (the seed's k_w)",
          unit="1/s", ge=0, le=10),
    Param("k_feedforward", float, 1.0, "share of the person's own speed away from the robot added to the forward "
          "speed (0: the seed's pure spring)", ge=0, le=1.5),
    Param("max_lin_acc", float, 1.0, "largest change of the forward speed per second (velocity_filter's limit)",
          unit="m/s^2", gt=0, le=3),
    Param("max_ang_acc", float, 1.0, "largest change of the turn rate per second", unit="rad/s^2", gt=0, le=10),
    Param("path_following", bool, True, "steer along the person's trail (through doorways, around corners) "
          "instead of straight at them"),
    Param("lookahead", float, 0.7, "how far ahead on the trail the robot steers to ...", unit="m", gt=0, le=3),
    Param("lookahead_time", float, 2.0, "... or, when farther, how far the robot drives in this long at its speed "
          "(2 s at 0.5 m/s: 1 m; 0: off)", unit="s", ge=0, le=5),
    Param("brake_turns", bool, True, "turn no faster than the turn can be stopped where the bearing comes to 0, "
          "braking at max_ang_acc after turn_latency: no overshoot past the heading steered to"),
    Param("turn_latency", float, 0.2, "the time a command takes to reach the wheels (follow_me, the multiplexer, the "
          "collision monitor, velocity_filter, the base), for brake_turns", unit="s", ge=0, le=1),
    Param("search_speed", float, 0.4, "forward speed while driving to where the person was last seen",
          unit="m/s", gt=0, le=0.5),
    Param("search_turn_rate", float, 0.6, "turn rate while looking for the person", unit="rad/s", gt=0, le=2),
)


TRAIL_SPACING = 0.1  # [m] between the trail's points
REACHED = 0.3  # [m] a trail point this near the robot is passed
TRAIL_LENGTH = 200  # points kept (20 m)
LOOP_RADIUS, LOOP_EXCESS = 0.25, 0.15  # [m] a person back this near a place they passed, on a way this much
# longer than the straight line, closed a loop
OWN_POINTS = 0.45  # [m] obstacle points this near the person are theirs (legs, body)
PAST_POINTS, PAST_SECONDS = 0.3, 1.5  # [m], [s] ... and so are points this near where they were this recently: a
# sensor's view of them a moment old (the Kinect's fake laser at 2 Hz, the scans' own lag) lies on their trail


@dataclass
class Limits:
    """The goal's limits after defaults: max_lin_speed [m/s], max_ang_speed [rad/s],
    desired_follow_distance [m]."""

    max_lin_speed: float
    max_ang_speed: float
    desired_distance: float


@dataclass
class Step:
    """One control cycle's output."""

    v: float  # [m/s]
    w: float  # [rad/s]
    mode: str  # FOLLOWING or SEARCHING
    person: tuple  # (x, y) [m] of the person (seen or expected) in the robot frame
    distance: float  # [m] to the person (expected, while searching)
    text: str


class Follower:
    """The controller of one goal. ``gains``: GAINS values (replace :attr:`gains` to retune live);
    ``rate`` [Hz] of :meth:`step`; ``lost_grace`` and ``lost_timeout`` [s]; ``clearance`` [m]: what
    the straight way to the point steered to keeps from the obstacle points :meth:`step` is given."""

    def __init__(self, gains, limits, rate, lost_grace=0.5, lost_timeout=10.0, search_standoff=0.4, clearance=0.3):
        self.gains = gains
        self.limits = limits
        self.dt = 1.0 / rate
        self.lost_grace = lost_grace
        self.lost_timeout = lost_timeout
        self.search_standoff = search_standoff
        self.trail = deque(maxlen=TRAIL_LENGTH)  # the person's positions in the fixed frame
        self.v = self.w = 0.0  # the last command
        self.lost = False  # unseen for longer than lost_timeout
        self._phase = "go"  # of a search: go (to where they were seen), face (where they headed), sweep
        self._sweep = 1.0  # direction of the sweep
        self._moved = None  # (t, (x, y)): when and where the search last moved on by SEARCH_PROGRESS
        self.obstacles = None  # [N, 2] obstacle points near the robot (fixed frame), for this cycle (step)
        self._required = clearance  # [m] this cycle's: what a straight way keeps from them (_passes)
        self.clearance = clearance
        self._recent = deque()  # (t, x, y) of the person over the last PAST_SECONDS

    # --- the trail -----------------------------------------------------------------------------
    def _record(self, xy):
        """Adds the person's place to the trail, without the loop of a person who turned back: back
        within LOOP_RADIUS of a point they passed, on a way from it LOOP_EXCESS longer than the straight
        line, the trail after that point is dropped (it leads away and back: the robot neither follows it
        nor counts its length)."""
        xy = (float(xy[0]), float(xy[1]))
        if self.trail and math.dist(self.trail[-1], xy) < TRAIL_SPACING:
            return
        if self.trail:
            pts = np.asarray(self.trail)
            steps = np.append(np.hypot(*np.diff(pts, axis=0).T), math.dist(self.trail[-1], xy))
            along = np.cumsum(steps[::-1])[::-1]  # [m] from each point to xy along the trail
            straight = np.hypot(pts[:, 0] - xy[0], pts[:, 1] - xy[1])
            back = np.flatnonzero((straight < LOOP_RADIUS) & (along - straight >= LOOP_EXCESS))
            if len(back):
                for _ in range(len(pts) - 1 - back[0]):
                    self.trail.pop()
                if math.dist(self.trail[-1], xy) < TRAIL_SPACING:
                    return
        self.trail.append(xy)

    def _steer_point(self, robot, goal_xy, lookahead=None):
        """The point (fixed frame) to steer to on the way to ``goal_xy`` along the trail, ``lookahead``
        [m] ahead on it (default: the gains')."""
        lookahead = self._lookahead() if lookahead is None else lookahead
        if not self.gains.path_following or not self.trail:
            return goal_xy
        pts = np.asarray(self.trail)
        d = np.hypot(pts[:, 0] - robot[0], pts[:, 1] - robot[1])
        start = int(np.argmin(d))  # the trail behind the nearest point is passed
        while start < len(pts) - 1 and d[start] < REACHED:
            start += 1
        for _ in range(start):
            self.trail.popleft()
        ahead = np.flatnonzero(d[start:] >= lookahead)
        if len(ahead) == 0 or math.dist(robot[:2], goal_xy) <= lookahead:
            if self._passes(robot, goal_xy) or len(pts) == start + 1:
                return goal_xy
            k = len(pts) - 1
        else:
            k = start + ahead[0]
        while k > start and not self._passes(robot, pts[k]):
            k -= 1  # nearer on the trail: the straight way to the farther point grazes what the robot sees
        return tuple(pts[k])

    def _lookahead(self):
        """[m] How far ahead on the trail the robot steers to: ``lookahead``, or farther at speed
        (``lookahead_time`` at the last command's speed), as adaptive pure pursuit does. At 0.5 m/s
        behind a walker through a doorway and round a corner (bench/enablers.py's walk, offline with
        commands 0.3 s late) 0.7 m kept the robot close to the corner and it lost ground turning
        there: distance error RMS 0.26 m, 0.14 m with 1.0 m (``lookahead_time`` 2 s); at an elderly
        person's 0.3 m/s, 0.7 m still (a longer one took the robot nearer than 0.8 of the desired
        distance as she turned behind the bedroom's door wall)."""
        g = self.gains
        return max(g.lookahead, g.lookahead_time * abs(self.v))

    def _passes(self, robot, xy):
        """Whether the straight way from the robot to ``xy`` keeps ``clearance`` [m] from every obstacle
        point (or, already nearer than that, no nearer than the robot is now)."""
        if self.obstacles is None:
            return True
        return float(np.min(pose2d.segment_distances(self.obstacles, robot[:2], xy))) >= self._required - 1e-9

    def _gap(self, robot, goal_xy, straight):
        """The distance [m] the spring keeps: along the person's trail (after :meth:`_steer_point` has
        dropped its passed part) where it bends, so that the robot comes on behind a person who turned a
        corner or went through a doorway and turned behind its wall, to where it sees them again, instead
        of standing at the desired distance straight with the wall between them (the demo lost the user
        so: she turned east behind the bedroom door's wall, 1 m from the robot in the corridor). The
        length beyond the straight distance counts only as far as the straight distance exceeds
        NEAR_SHARE of the desired one: a trail that doubles back never brings the robot nearer than
        (1 + NEAR_SHARE) / 2 of the desired distance."""
        if not self.gains.path_following or not self.trail:
            return straight
        along, last = 0.0, robot[:2]
        for p in self.trail:
            step = math.dist(last, p)
            if step >= CORNER_SPACING and math.dist(p, goal_xy) >= CORNER_SPACING:  # their last steps: straight
                along, last = along + step, p
        along += math.dist(last, goal_xy)
        extra = max(0.0, along - straight)
        return straight + min(extra, max(0.0, straight - NEAR_SHARE * self.limits.desired_distance))

    # --- control -------------------------------------------------------------------------------------
    def _command(self, v, w):
        g = self.gains
        v = clamp(v, self.limits.max_lin_speed)
        w = clamp(w, self.limits.max_ang_speed)
        self.v = step_towards(self.v, v, g.max_lin_acc * self.dt)
        self.w = step_towards(self.w, w, g.max_ang_acc * self.dt)
        return self.v, self.w

    def step(self, t, robot, person, obstacles=None):
        """One cycle at ``t`` [s]: ``robot`` (x, y, yaw) in the fixed frame, ``person`` the
        florence_common.people.AttendedPerson (updated by the caller with the tracker's reports),
        ``obstacles`` [N, 2] what the robot sees (fixed frame; None: nothing known)."""
        g, lim = self.gains, self.limits
        self.obstacles = None
        self._recent.append((t, float(person.xy[0]), float(person.xy[1])))
        while self._recent and self._recent[0][0] < t - PAST_SECONDS:
            self._recent.popleft()
        if obstacles is not None and len(obstacles):
            o = np.asarray(obstacles, dtype=float).reshape(-1, 2)
            near = np.hypot(o[:, 0] - robot[0], o[:, 1] - robot[1])
            keep = (near <= self._lookahead() + self.clearance + 0.1) & (
                np.hypot(o[:, 0] - person.xy[0], o[:, 1] - person.xy[1]) > OWN_POINTS)
            o, near = o[keep], near[keep]  # the few points in reach, before the distances to her recent places
            past = np.asarray(self._recent)[:, 1:]
            hers = np.min(np.hypot(o[:, None, 0] - past[None, :, 0], o[:, None, 1] - past[None, :, 1]), axis=1,
                          initial=np.inf) <= PAST_POINTS
            if not np.all(hers):
                # the clearance a straight way must keep: or, already nearer, no nearer than the robot is now
                self.obstacles, self._required = o[~hers], min(self.clearance, float(np.min(near[~hers])))
        unseen = person.unseen_for(t)
        expected = person.expected(t)
        local = pose2d.transform_points(pose2d.inverse(robot), [expected])[0]
        distance = math.hypot(local[0], local[1])
        if unseen <= self.lost_grace:
            self._phase = "go"
            self._moved = None
            self._record(person.xy)
            target = self._steer_point(robot, expected)
            tx, ty = pose2d.transform_points(pose2d.inverse(robot), [target])[0]
            theta = math.atan2(ty, tx)
            ux, uy = (expected[0] - robot[0]) / max(distance, 1e-6), (expected[1] - robot[1]) / max(distance, 1e-6)
            away = person.velocity[0] * ux + person.velocity[1] * uy  # [m/s] the person's speed away from the robot
            gap = self._gap(robot, expected, distance)
            v = g.k_distance * (gap - lim.desired_distance) + g.k_feedforward * away
            v *= max(0.0, math.cos(theta))
            w = g.k_bearing * theta
            if g.brake_turns:
                w = math.copysign(min(abs(w), braking_speed(abs(theta), g.max_ang_acc, g.turn_latency)), theta)
            v, w = self._command(v, w)
            return Step(v, w, FOLLOWING, (float(local[0]), float(local[1])), distance,
                        f"following {person.pid} at {distance:.2f} m")
        if unseen > self.lost_timeout:
            self.lost = True
        return self._search(t, robot, person, unseen, (float(local[0]), float(local[1])), distance)

    def _search(self, t, robot, person, unseen, local, distance):
        """Where the person was last seen, then where they were heading, then around. The way there is
        to the place they were last seen, along their trail: a place somebody stood, where the robot
        fits; their expected place, carried on by their velocity, may be behind the wall they turned
        around (the robot pushed into a bedroom door's jamb for 8 s while she walked on out of view).
        A person last seen standing still (slower than STILL_SPEED) may stand there yet, unseen by the
        tracker close up: the robot goes no nearer than the desired distance to the place (it drove to
        within 0.54 m of a person who stopped 1.1 m before it and whom the tracker dropped there). When the
        robot does not move on for SEARCH_PATIENCE s (an obstacle in the way: the collision
        monitor holds it), it looks from where it is. Along the trail it steers SEARCH_LOOKAHEAD ahead,
        through the doorway the person took rather than across its jamb."""
        g = self.gains
        text = f"searching for {person.pid}, unseen for {unseen:.1f} s"
        seen_at = math.dist(robot[:2], person.xy)
        # where a person standing still was lost, they may stand yet: no nearer than the desired distance
        still = math.hypot(*person.velocity) < STILL_SPEED
        standoff = max(self.search_standoff, self.limits.desired_distance) if still else self.search_standoff
        if self._phase == "go" and seen_at > standoff + 0.05:  # to where they were last seen
            if self._moved is None or math.dist(robot[:2], self._moved[1]) >= SEARCH_PROGRESS:
                self._moved = (t, (float(robot[0]), float(robot[1])))
            if t - self._moved[0] <= SEARCH_PATIENCE:
                target = self._steer_point(robot, person.xy, min(g.lookahead, SEARCH_LOOKAHEAD))
                tx, ty = pose2d.transform_points(pose2d.inverse(robot), [target])[0]
                theta = math.atan2(ty, tx)
                v = min(g.search_speed, g.k_distance * (seen_at - standoff)) * max(0.0, math.cos(theta))
                v, w = self._command(v, g.k_bearing * theta)
                return Step(v, w, SEARCHING, local, distance, text + ": going to where they were last seen")
            text += f" (held up for {SEARCH_PATIENCE:g} s)"
        if self._phase == "go":
            self._phase = "face"
        heading = person.velocity
        if self._phase == "face" and math.hypot(*heading) > 0.1:  # toward where they were heading
            turn = diff(math.atan2(heading[1], heading[0]), robot[2])
            if abs(turn) > 0.2:
                v, w = self._command(0.0, clamp(g.k_bearing * turn, g.search_turn_rate))
                return Step(v, w, SEARCHING, local, distance, text + ": turning to where they were heading")
            self._sweep = 1.0 if turn >= 0 else -1.0
        self._phase = "sweep"
        v, w = self._command(0.0, self._sweep * g.search_turn_rate)
        return Step(v, w, SEARCHING, local, distance, text + ": looking around")

    def stop(self):
        self.v = self.w = 0.0
