"""People in the costmaps (ROS-free): social_navigation_layers' ProxemicLayer, with Florence's
lethal core, and the geometry move_base needs to wait for a person or give way to one.

The proxemic cost around a person at (px, py) walking at (vx, vy) is ProxemicLayer's Gaussian,

    cost = amplitude * exp(-(a^2 / (2 var_a) + c^2 / (2 covariance)))

with ``a`` the distance along the person's heading (the direction of their velocity) and ``c``
across it; ``var_a`` is ``covariance * (1 + |v| * factor)`` in front of the person (a >= 0) and
``covariance`` behind, so the cost stretches ahead of a walker. Cells where it is below
``cutoff`` are left alone; elsewhere a cell takes the larger of its cost and this one (an
unknown cell stays unknown). ROS's defaults: amplitude 77, covariance 0.25 m^2, cutoff 10,
factor 5 s/m, keep_time 0.75 s.

Florence's additions: ``lethal_radius`` [m] makes the disc round each person lethal, before the
inflation, so that a plan keeps the robot's centre at least lethal_radius + the inscribed radius
from them (0: none, as ROS); with ``follow_speed`` > 0, a person walking away from the robot at
least that fast gets no lethal disc and their obstacle marks are freed (:func:`walking_away`): a
resident walking ahead along a corridor the robot must take leaves it only at its far end, so a
plan round them would wait for ever; the robot follows them instead, and the local planner's
min_person_distance, which walks them on at their velocity, keeps the gap. A person lapses
``keep_time`` after the tracker last saw them (the person is gone from the costmap once their
track is gone; ROS keeps the last message's people until the next message). Positions are
carried forward along the velocity to the update's time (at most keep_time).

Units: metres, seconds, radians; positions in the costmap's frame.
"""

import math
from dataclasses import dataclass

import numpy as np

from florence_common.params import Param, ParamTable
from move_base.costmap_2d import LETHAL_OBSTACLE, NO_INFORMATION

CARRY_LIMIT = 0.5  # [s] how far along their velocity a person's position is carried
# A person's heading is remembered from their last message at HEADING_SPEED [m/s] or faster for
# HEADING_KEEP [s] (headings): one who stopped for the robot goes on that way when it leaves (the
# simulated residents turn back after waiting 10 s; people wait longer)
HEADING_SPEED = 0.2
HEADING_KEEP = 15.0
SENT_TO_ID = -2  # the id current() gives the person the robot is sent to when no track holds her (sent_to)

PROXEMIC_PARAMS = ParamTable(
    Param("amplitude", float, 77.0, "cost at a person's centre", ge=0.0, le=252.0),
    Param("covariance", float, 0.25, "variance of the Gaussian across the heading and behind", unit="m^2", gt=0.0),
    Param("cutoff", float, 10.0, "smallest cost written (the Gaussian's edge)", ge=0.0),
    Param("factor", float, 5.0, "stretch of the variance ahead of a walker per m/s of speed", unit="s/m", ge=0.0),
    Param("keep_time", float, 0.75, "a person lapses this long after the tracker last saw them", unit="s",
          gt=0.0),
    Param("lethal_radius", float, 0.0, "Florence: the disc of this radius round a person is lethal (0: none, as "
          "ROS)", unit="m", ge=0.0),
    Param("trail_time", float, 5.0, "Florence: the obstacle marks within trail_radius of where a tracked person "
          "was in this time are theirs and freed before each update's marking (what a sensor sees there now is "
          "marked again; 0: none)", unit="s", ge=0.0),
    Param("trail_radius", float, 0.3, "Florence: see trail_time (a person's body about their tracked centre)",
          unit="m", ge=0.0),
    Param("unseen_keep_time", float, 0.0, "Florence: a person past keep_time whose last place the sensors do not "
          "see now (outside view_angle or view_range of the robot, or behind a wall of the map) is kept until this "
          "long after they were last seen; one the sensors look at and do not find lapses (0: none)", unit="s",
          ge=0.0),
    Param("view_angle", float, 4.19, "Florence: the sensors' field of view about the robot's heading (the "
          "Hokuyo's 240 degrees) for unseen_keep_time", unit="rad", gt=0.0, le=2.0 * math.pi),
    Param("view_range", float, 4.0, "Florence: how far the tracker sees people, for unseen_keep_time", unit="m",
          gt=0.0),
    Param("follow_speed", float, 0.0, "Florence: a person walking away from the robot at least this fast (their "
          "speed along the line from the robot's centre to theirs) is followed, not planned round: no lethal disc, "
          "and the obstacle marks within trail_radius of them are freed after each update's marking (0: none)",
          unit="m/s", ge=0.0),
)
"""A costmap's proxemic layer (``~<costmap>/proxemic/``: ProxemicLayer's names and defaults plus
Florence's lethal_radius, trail_time, trail_radius and follow_speed)."""


@dataclass
class Person:
    """One tracked person in the costmap's frame: position [m], velocity [m/s], last seen [s]."""

    x: float
    y: float
    vx: float
    vy: float
    seen: float
    id: int = -1


class ProxemicLayer:
    """The people's costs (see the module docstring); ``params``: :data:`PROXEMIC_PARAMS`' values."""

    def __init__(self, amplitude=77.0, covariance=0.25, cutoff=10.0, factor=5.0, keep_time=0.75, lethal_radius=0.0,
                 trail_time=5.0, trail_radius=0.3, unseen_keep_time=0.0, view_angle=4.19, view_range=4.0,
                 follow_speed=0.0):
        self.amplitude = float(amplitude)
        self.covariance = float(covariance)
        self.cutoff = float(cutoff)
        self.factor = float(factor)
        self.keep_time = float(keep_time)
        self.lethal_radius = float(lethal_radius)
        self.trail_time = float(trail_time)
        self.trail_radius = float(trail_radius)
        self.unseen_keep_time = float(unseen_keep_time)
        self.view_angle = float(view_angle)
        self.view_range = float(view_range)
        self.follow_speed = float(follow_speed)
        self._people = {}  # id -> (Person, stamp [s] of the message it came in)
        self._unseen = set()  # ids past keep_time kept because their place is out of the sensors' view (observe)
        self._stamp = None  # [s] the newest message's time
        self._trail = []  # (t [s], x [m], y [m]) of every tracked person of the last trail_time
        self._sent_to = None  # (x [m], y [m], until [s]): the person the robot is sent to (sent_to)
        self._headings = {}  # id -> (t [s], ux, uy): the way a person last walked (headings)

    def sent_to(self, x, y, until):
        """The person the robot is sent to (move_base's ~approach_target) stands at (x, y) [m] until
        ``until`` [s]: while no tracked person is within APPROACH_MATCH of her she is one, still (the
        tracker drops a seated user the robot turns its back on, and a plan to her front then
        flipped between the way round the furniture, with her there, and the gap past her, 8 s
        later without her, at every turn). Not finite: ignored."""
        if all(math.isfinite(v) for v in (x, y, until)):
            self._sent_to = (float(x), float(y), float(until))

    def set_people(self, people, stamp):
        """The people of the newest tracker message (an iterable of :class:`Person`), ``stamp`` [s]
        its time. People with a non-finite field are dropped; returns how many. A person the
        message no longer holds is kept until keep_time after they were last seen (the tracker drops
        a track its sensors lost, as the robot turns away from a person: the person is still there)."""
        dropped = 0
        stamp = float(stamp)
        for p in people:
            values = (p.x, p.y, p.vx, p.vy, p.seen)
            if all(math.isfinite(v) for v in values):
                self._people[p.id] = (p, stamp)
                self._trail.append((p.seen, p.x, p.y))
                speed = math.hypot(p.vx, p.vy)
                if speed >= HEADING_SPEED:
                    self._headings[p.id] = (p.seen, p.vx / speed, p.vy / speed)
            else:
                dropped += 1
        self._stamp = stamp
        self._people = {k: v for k, v in self._people.items() if self._kept(v[0], stamp)}
        self._unseen &= self._people.keys()  # held ones past unseen_keep_time are gone
        self._headings = {k: v for k, v in self._headings.items() if k in self._people and stamp - v[0] <= HEADING_KEEP}
        return dropped

    def headings(self, ids):
        """(P, 2) the unit heading each of ``ids`` (:meth:`current`'s) last walked on at
        HEADING_SPEED or faster within HEADING_KEEP of the newest message; NaN where none."""
        out = np.full((len(ids), 2), np.nan)
        for i, pid in enumerate(ids):
            if pid in self._headings:
                out[i] = self._headings[pid][1:]
        return out

    def _kept(self, person, now):
        """Whether ``person`` still counts at ``now`` [s]: seen within keep_time, or within
        unseen_keep_time and not yet found missing by :meth:`observe` (which deletes a person the
        sensors look at and do not hold)."""
        return now - person.seen <= max(self.keep_time, self.unseen_keep_time)

    def observe(self, now, x, y, yaw, hidden=None):
        """``unseen_keep_time``: the robot at (x, y, yaw) [m, m, rad; yaw None: unknown, every
        heading sees] at ``now`` [s]. Each person past
        keep_time is held while their last place is out of the sensors' view (farther than
        view_range, outside view_angle about the heading, or ``hidden(x0, y0, x1, y1)`` [m] says the
        line of sight is blocked) and lapses as soon as it is in view (the tracker would hold them
        there) or unseen_keep_time after they were last seen. Why: the tracker drops a person the
        robot turns its back on; forgotten keep_time later, a person standing in the corridor the
        robot had planned round was no longer in the way, the plan flipped back through them, the
        robot turned, saw them, and the plan flipped again (bench/nav.py seed 1, leg 3: six such
        turns in 45 s). Returns how many are held."""
        if self.unseen_keep_time <= 0.0:
            self._unseen.clear()
            return 0
        for pid, (p, _) in list(self._people.items()):
            age = now - p.seen
            if age <= self.keep_time:
                self._unseen.discard(pid)
                continue
            dx, dy = p.x - x, p.y - y
            seen = (math.hypot(dx, dy) <= self.view_range
                    and (yaw is None
                         or abs(math.remainder(math.atan2(dy, dx) - yaw, 2.0 * math.pi)) <= 0.5 * self.view_angle)
                    and not (hidden is not None and hidden(x, y, p.x, p.y)))
            if seen or age > self.unseen_keep_time:
                del self._people[pid]
                self._unseen.discard(pid)
            else:
                self._unseen.add(pid)
        return len(self._unseen)

    def release_unseen(self):
        """Forget the people held out of view (:meth:`observe`); returns how many there were."""
        held = len(self._unseen)
        for pid in self._unseen:
            self._people.pop(pid, None)
        self._unseen.clear()
        return held

    def clear(self):
        self._unseen = set()
        self._people = {}
        self._stamp = None
        self._trail = []
        self._sent_to = None
        self._headings = {}

    def trail(self, now=None):
        """(N, 3) x, y [m], trail_radius: where tracked people were within trail_time before
        ``now`` [s] (None: the last message's time), thinned to one disc per trail_radius / 2 of
        walking; empty when trail_time is 0."""
        if self.trail_time <= 0.0 or not self._trail:
            return np.zeros((0, 3))
        now = self._stamp if now is None else now
        self._trail = [row for row in self._trail if now - row[0] <= self.trail_time]
        if not self._trail:
            return np.zeros((0, 3))
        xy = np.array([row[1:] for row in self._trail])
        cells = np.floor(xy / max(self.trail_radius / 2.0, 1e-3)).astype(np.int64)
        _, first = np.unique(cells, axis=0, return_index=True)
        xy = xy[np.sort(first)]
        return np.column_stack([xy, np.full(len(xy), self.trail_radius)])

    def current(self, now=None):
        """The people at ``now`` [s] (None: as last reported) not lapsed (seen within keep_time),
        each moved along its velocity from the time of the message that held it to ``now`` (at
        most CARRY_LIMIT: a lost track's velocity is not a forecast), and the person the robot is
        sent to where no track holds her (:meth:`sent_to`, id SENT_TO_ID): (N, 4) array of (x, y,
        vx, vy) and their ids."""
        rows, ids = [], []
        for pid, (p, stamp) in self._people.items():
            if now is not None and not self._kept(p, now):
                continue
            ahead = 0.0 if now is None else min(max(now - stamp, 0.0), CARRY_LIMIT)
            rows.append((p.x + p.vx * ahead, p.y + p.vy * ahead, p.vx, p.vy))
            ids.append(pid)
        if self._sent_to is not None:
            x, y, until = self._sent_to
            t = now if now is not None else self._stamp
            if (t is None or t <= until) and not any(math.hypot(r[0] - x, r[1] - y) <= APPROACH_MATCH for r in rows):
                rows.append((x, y, 0.0, 0.0))
                ids.append(SENT_TO_ID)
        return np.array(rows, dtype=float).reshape(-1, 4), ids

    def followed(self, now, robot):
        """(N, 4) x, y [m], vx, vy [m/s]: the people at ``now`` [s] (:meth:`current`) walking away
        from ``robot`` = (x, y) [m] at least follow_speed (none when follow_speed is 0)."""
        people, _ = self.current(now)
        return people[self._walking_away(people, robot)]

    def _walking_away(self, people, robot):
        """Which of ``people`` (P, 4) walk away from ``robot`` (x, y, ...) [m] at least
        follow_speed (none when follow_speed is 0 or the robot's place is unknown)."""
        if self.follow_speed <= 0.0 or robot is None:
            return np.zeros(len(people), dtype=bool)
        return walking_away(people, robot[0], robot[1], self.follow_speed)

    def radius(self, speed=0.0):
        """Reach [m] of the cost round a person walking at ``speed`` [m/s] (ProxemicLayer's
        get_radius of the stretched variance), at least lethal_radius."""
        if self.cutoff >= self.amplitude or self.amplitude <= 0.0:
            return self.lethal_radius
        var = self.covariance * (1.0 + speed * self.factor)
        return max(self.lethal_radius, math.sqrt(-2.0 * var * math.log(self.cutoff / self.amplitude)))

    def update_costs(self, master, now=None, robot=None):
        """Write the people's costs into ``master`` (a Costmap2D) for time ``now`` [s]. ``robot`` =
        (x, y, keep_clear) [m]: no lethal cell within keep_clear of the robot's centre, so that a
        person standing close does not wall the robot in (a plan from its cell could not start)."""
        people, _ = self.current(now)
        away = self._walking_away(people, robot)  # followed: no lethal core
        for (px, py, vx, vy), followed in zip(people, away, strict=True):
            self._write_person(master, px, py, vx, vy, robot, lethal=not followed)

    def _write_person(self, master, px, py, vx, vy, robot=None, lethal=True):
        speed = math.hypot(vx, vy)
        reach = self.radius(speed)
        res = master.resolution
        lo_x = max(math.floor((px - reach - master.origin_x) / res), 0)
        hi_x = min(math.floor((px + reach - master.origin_x) / res), master.size_x - 1)
        lo_y = max(math.floor((py - reach - master.origin_y) / res), 0)
        hi_y = min(math.floor((py + reach - master.origin_y) / res), master.size_y - 1)
        if lo_x > hi_x or lo_y > hi_y:
            return
        cx = master.origin_x + (np.arange(lo_x, hi_x + 1) + 0.5) * res
        cy = master.origin_y + (np.arange(lo_y, hi_y + 1) + 0.5) * res
        dx, dy = np.meshgrid(cx - px, cy - py)
        heading = math.atan2(vy, vx)
        c, s = math.cos(heading), math.sin(heading)
        along = c * dx + s * dy
        across = -s * dx + c * dy
        var_along = np.where(along >= 0.0, self.covariance * (1.0 + speed * self.factor), self.covariance)
        cost = self.amplitude * np.exp(-(along * along / (2.0 * var_along) + across * across / (2.0 * self.covariance)))
        window = master.costs[lo_y:hi_y + 1, lo_x:hi_x + 1]
        known = window != NO_INFORMATION
        write = known & (cost >= self.cutoff)
        window[write] = np.maximum(window[write], cost[write].astype(np.uint8))
        if self.lethal_radius > 0.0 and lethal:
            core = np.hypot(dx, dy) <= self.lethal_radius
            if robot is not None:
                rx, ry, keep_clear = robot
                core &= np.hypot(dx + px - rx, dy + py - ry) > keep_clear
            window[core] = LETHAL_OBSTACLE


# --- the local planner's rule and move_base's waiting -------------------------------------------------
# Giving way (move_base's WAITING state): the place the robot drives to is at least
# GIVE_WAY_MIN_DISTANCE from every person and GIVE_WAY_KEEP_OFF from the line each walks along (a
# person passing a robot keeps about 0.5 m between the centres, and the tracker's positions are off
# by up to about 0.1 m), on a costmap cell below GIVE_WAY_MAX_COST (not pressed against a wall).
GIVE_WAY_MIN_DISTANCE = 1.0  # [m]
GIVE_WAY_KEEP_OFF = 0.75  # [m]
GIVE_WAY_MAX_COST = 200
# A person who stands waiting for the robot goes on past where it stood, and not necessarily straight:
# beyond the robot their way widens by this much across per metre along (tan 30 degrees). Without it the
# bench's robot gave way from a kitchen door 0.96 m to the side but 1.5 m on into the kitchen, where
# the resident who had waited at the door then walked (nav100 seed 1, leg 35: 0.38 m between centres).
GIVE_WAY_FAN = math.tan(math.radians(30.0))
# A place to give way is within this distance [m] of the robot: giving way is a step aside, not a
# journey (nav bench seed 2, 1 Dec, leg 54: with 146 unmapped returns near it in the corridor the
# nearest place off every one's line was 4.05 m away, through the living room; the robot went there
# and back, 117 s for the leg). Beyond it the robot waits where it stands.
GIVE_WAY_REACH = 2.0
STILL_MARGIN = 0.1  # [m] a leg's distance from a person's centre


def walking_away(people, x, y, speed):
    """Which of ``people`` (P, 4) x, y [m], vx, vy [m/s] walk away from (x, y) [m] at least
    ``speed`` [m/s] (their velocity's component along the line from (x, y) to them; a person at
    (x, y) walks away from nobody). Returns a bool array (P,)."""
    people = np.asarray(people, dtype=float).reshape(-1, 4)
    rx, ry = people[:, 0] - x, people[:, 1] - y
    d = np.hypot(rx, ry)
    radial = (people[:, 2] * rx + people[:, 3] * ry) / np.maximum(d, 1e-9)
    return (d > 1e-6) & (radial >= speed)


def near_walks(points, people, radius, back):
    """Which ``points`` (N, 2) [m] lie within ``radius`` [m] of where one of ``people`` (P, 4)
    walked in the last ``back`` [s] at their velocity (the segment from (x - vx back, y - vy back)
    to (x, y)): their legs, seen there lately. Returns a bool array (N,)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    people = np.asarray(people, dtype=float).reshape(-1, 4)
    out = np.zeros(len(points), dtype=bool)
    for px, py, vx, vy in people:
        sx, sy = -vx * back, -vy * back
        length2 = sx * sx + sy * sy
        dx, dy = points[:, 0] - px, points[:, 1] - py
        u = np.clip((dx * sx + dy * sy) / length2, 0.0, 1.0) if length2 > 1e-12 else 0.0
        out |= np.hypot(dx - u * sx, dy - u * sy) <= radius
    return out


def backs_toward(points, people, distance):
    """Which trajectories back up (their end lies behind their start along the start's heading)
    while one of ``people`` (P, 4) stands within ``distance`` [m] of the start, behind it (in the
    half-plane behind the robot): the sensors do not see there, and a person the robot turned its
    back on may have walked up to it since. ``points`` (K, T, >= 3) [m, m, rad]. Returns (K,) bool."""
    points = np.asarray(points, dtype=float)
    people = np.asarray(people, dtype=float).reshape(-1, 4)
    out = np.zeros(points.shape[0], dtype=bool)
    if not len(people) or points.size == 0:
        return out
    x0, y0, th = points[0, 0, 0], points[0, 0, 1], points[0, 0, 2]
    hx, hy = math.cos(th), math.sin(th)
    rx, ry = people[:, 0] - x0, people[:, 1] - y0
    if not np.any((np.hypot(rx, ry) <= distance) & (rx * hx + ry * hy < 0.0)):
        return out
    ends = points[:, -1, :2]
    return (ends[:, 0] - points[:, 0, 0]) * hx + (ends[:, 1] - points[:, 0, 1]) * hy < -0.01


def braking_positions(times, start, speed, acc):
    """Positions (x, y) [m] at ``times`` [s] (any shape) of a robot braking from ``speed`` [m/s]
    at ``acc`` [m/s^2] straight along its heading from ``start`` = (x, y, yaw): what the robot
    does at the least when it stops commanding motion. Returns two arrays of ``times``' shape."""
    t = np.asarray(times, dtype=float)
    v = abs(float(speed))
    a = max(float(acc), 1e-9)
    t_stop = v / a
    tc = np.minimum(t, t_stop)
    s = np.sign(speed) * (v * tc - 0.5 * a * tc * tc)
    return start[0] + s * math.cos(start[2]), start[1] + s * math.sin(start[2])


# The person the robot is sent to on purpose (approach_me_map's goal 0.5 m from the user): the tracked
# person nearest the announced point within APPROACH_MATCH, and the leg-height returns within
# APPROACH_LEGS of her (a seated person's shins reach 0.3-0.4 m in front of her centre, the chair's
# legs round her) are hers, not strangers standing there.
APPROACH_MATCH = 0.5  # [m]
APPROACH_LEGS = 0.6  # [m]


def approach_exemption(people, still, target, distance, min_distance):
    """The local planner's distances for ``people`` (P, 4) when the robot is sent to the person at
    ``target`` (x, y) [m] (None: nobody): (P,) ``min_distance`` [m] for everybody but the tracked
    person nearest the target within APPROACH_MATCH, who gets ``distance`` [m]; and ``still`` (S, 2)
    less the points within APPROACH_LEGS of her (of the target when nobody is tracked there: the
    tracker may have lost her as the robot came close). Returns (distances (P,), still (S', 2), index of
    her in ``people`` or -1)."""
    people = np.asarray(people, dtype=float).reshape(-1, 4)
    still = np.zeros((0, 2)) if still is None else np.asarray(still, dtype=float).reshape(-1, 2)
    out = np.full(len(people), float(min_distance))
    if target is None or not np.all(np.isfinite(target)):
        return out, still, -1
    tx, ty = float(target[0]), float(target[1])
    index, cx, cy = -1, tx, ty
    if len(people):
        d = np.hypot(people[:, 0] - tx, people[:, 1] - ty)
        i = int(np.argmin(d))
        if d[i] <= APPROACH_MATCH:
            index, cx, cy = i, people[i, 0], people[i, 1]
            out[i] = float(distance)
    if len(still):
        still = still[np.hypot(still[:, 0] - cx, still[:, 1] - cy) > APPROACH_LEGS]
    return out, still, index


# [m] approaches(brake=...): a trajectory this near the braking positions throughout is braking (a
# robot at 0.3 m/s turning at 1 rad/s as it brakes at 0.5 m/s^2 strays 0.023 m from the straight line)
BRAKING_TOLERANCE = 0.05


def approaches(points, times, people, min_distance, tolerance=0.01, brake=None, still=None, per_person=None,
               yield_speed=0.0):
    """Which trajectories bring the robot's centre nearer than ``min_distance`` [m] to a person
    than braking would: trajectory k is refused when at some step i its position is within
    ``min_distance`` of where a person will be at ``times[k, i]`` [s] (walking on at their
    velocity) and nearer to it, by more than ``tolerance`` [m], than a robot braking to a stop
    from ``brake`` = (x, y, yaw, speed [m/s], deceleration [m/s^2]) would be then (None: standing
    at the trajectory's first pose). Braking, turning on the spot and moving away from a person
    are never refused, so a robot a person walked up to can always leave.

    With ``brake`` given, a trajectory that is not braking (off the braking positions by more
    than :data:`BRAKING_TOLERANCE` at some step: a braking turn strays a little) is also refused
    when within the distance it comes nearer to the person than a robot standing at its first
    pose would be. Braking alone is no licence: a robot driving toward a person could otherwise
    curve past them, each cycle a little less near than braking straight on would bring it, and
    close in all the same (bench/nav.py seed 3, 29 Nov: an arc past Alice standing at her
    waypoint from 0.53 m to 0.42 m between centres, 0.26 m from her legs).

    ``yield_speed`` [m/s] > 0, with ``brake`` given: a person walking at least that fast is given
    way to. A trajectory that is not braking (off the braking positions by more than
    :data:`BRAKING_TOLERANCE` at some step) is refused when at some step it is within their
    distance of where they will be, whichever of the two closes in: the robot stops and turns on
    the spot while a walker passes near or comes up to it, and drives on only where they do not
    come that near (away from them, or once they have passed).

    ``points`` (K, T, >= 2) [m], ``times`` (K, T) [s] (np.inf past a trajectory's last step),
    ``people`` (P, 4) (x, y, vx, vy); ``per_person`` (P,) [m]: each person's distance instead of
    ``min_distance`` (the person approached on purpose: :func:`approach_exemption`; None: all
    ``min_distance``); ``still`` (S, 2) [m] points that may be people standing (the
    legs of a person the tracker does not know), kept at ``min_distance`` - STILL_MARGIN (a leg is
    about 0.1 m from the person's centre, and nearest when the robot comes from the side, where
    the centre is then farther still). Returns a bool array (K,)."""
    points = np.asarray(points, dtype=float)
    out = np.zeros(points.shape[0], dtype=bool)
    people = np.asarray(people, dtype=float).reshape(-1, 4)
    still = np.zeros((0, 2)) if still is None else np.asarray(still, dtype=float).reshape(-1, 2)
    per_person = np.full(len(people), float(min_distance)) if per_person is None else \
        np.asarray(per_person, dtype=float).reshape(len(people))
    if (len(people) == 0 and len(still) == 0) or min_distance <= 0.0 or points.size == 0:
        return out
    t = np.asarray(times, dtype=float)
    valid = np.isfinite(t)
    t = np.where(valid, t, 0.0)
    sx, sy = points[:, :1, 0], points[:, :1, 1]  # standing at the first pose
    if brake is None:
        bx, by, off_braking = sx, sy, None
    else:
        bx, by = braking_positions(t, brake[:3], brake[3], brake[4])
        off_braking = np.hypot(points[..., 0] - bx, points[..., 1] - by) > BRAKING_TOLERANCE
    for (px, py, vx, vy), keep in zip(people, per_person, strict=True):
        if keep <= 0.0:
            continue
        qx, qy = px + vx * t, py + vy * t  # (K, T) the person at each step's time
        d = np.hypot(points[..., 0] - qx, points[..., 1] - qy)
        refused = d < np.hypot(bx - qx, by - qy) - tolerance
        if off_braking is not None:
            refused |= off_braking & (d < np.hypot(sx - qx, sy - qy) - tolerance)
            if yield_speed > 0.0 and math.hypot(vx, vy) >= yield_speed:
                refused |= off_braking
        out |= np.any(valid & (d < keep) & refused, axis=1)
    if len(still):
        from scipy.spatial import cKDTree

        tree = cKDTree(still)
        shape = points.shape[:2]
        near = min_distance - STILL_MARGIN
        d = tree.query(points[..., :2].reshape(-1, 2), distance_upper_bound=near)[0].reshape(shape)
        base = np.column_stack([np.broadcast_to(bx, shape).ravel(), np.broadcast_to(by, shape).ravel()])
        refused = d < tree.query(base)[0].reshape(shape) - tolerance
        if off_braking is not None:
            standing = tree.query(np.column_stack([sx[:, 0], sy[:, 0]]))[0].reshape(-1, 1)
            refused |= off_braking & (d < standing - tolerance)
        out |= np.any(valid & (d < near) & refused, axis=1)
    return out


class RecentPoints:
    """Points [m] seen within the last ``keep`` [s]: the leg-height returns of people the tracker
    does not know stay remembered for a moment after the robot turned away from them."""

    def __init__(self, keep=1.5):
        self.keep = float(keep)
        self._rows = []  # (t [s], (N, 2) points)

    def add(self, now, points):
        self._rows = [(t, p) for t, p in self._rows if 0.0 <= now - t <= self.keep]
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if len(points):
            self._rows.append((float(now), points))

    def get(self, now):
        """The points of the last ``keep`` seconds before ``now`` [s], (N, 2)."""
        rows = [p for t, p in self._rows if 0.0 <= now - t <= self.keep]
        return np.concatenate(rows) if rows else np.zeros((0, 2))


def blocked_plan_reason(near, map_has_way, waiting=False):
    """Why a failed plan is people's doing, or '': the maps alone (static and keep-out) have a way,
    so what the sensors marked since blocks it, and ``near`` says what they see near the robot now.
    When they see nothing there now, a wait goes on (``waiting``) but none starts: the marks were
    made earlier and are out of view now (the robot turned away to give way; test_nav_sim's doorway
    ended its wait there, ran the recoveries and aborted without saying people were in the way),
    while a stale mark of someone who left is the recoveries' to clear, at once."""
    if not map_has_way:
        return ""
    if near:
        return f"{near} stands in the way (the map has a way)"
    if waiting:
        return ("something the map does not have, marked by the sensors and out of their view now, stands in "
                "the way (the map has a way)")
    return ""


def give_way_cells(potential, costmap, robot_xy, people, keep_off, min_distance, headings=None,
                   reach=GIVE_WAY_REACH):
    """Where the robot could stand to let people by: the reachable cell (finite ``potential``, a
    navfn potential from the robot over ``costmap``) within ``reach`` [m] of the robot, of least
    potential, at least ``min_distance`` [m] from every person and at least ``keep_off`` [m] from every person's way,
    the line through the person toward the robot (a person who stands in the robot's way waits
    for it to leave the line they walk along), on the robot's side of each person. Returns the
    cell's centre (x, y) [m] or None.

    ``people`` (P, 4) (x, y, vx, vy); a walking person's way is their heading instead. A still
    person's way widens beyond the robot by GIVE_WAY_FAN across per metre along: where they go after
    the place the robot leaves is not known. ``headings`` (P, 2): the unit heading a still person
    last walked on (NaN: unknown; :meth:`ProxemicLayer.headings`); the way on along it is theirs
    too, ahead of them (nav bench seed 2: a resident who stopped for the robot in the kitchen's
    opening was taken for someone who only wanted the robot's place, and the robot gave way 1 m
    on along the line she had been walking; 8 s later, there, the two were 0.39 m apart, 17 mm
    between bodies)."""
    people = np.asarray(people, dtype=float).reshape(-1, 4)
    headings = (np.full((len(people), 2), np.nan) if headings is None
                else np.asarray(headings, dtype=float).reshape(len(people), 2))
    ok = np.isfinite(potential)
    if not ok.any():
        return None
    rows, cols = np.nonzero(ok)
    wx, wy = costmap.map_to_world(cols, rows)
    wx, wy = np.atleast_1d(wx), np.atleast_1d(wy)
    good = np.hypot(wx - robot_xy[0], wy - robot_xy[1]) <= reach
    for (px, py, vx, vy), (hx, hy) in zip(people, headings, strict=True):
        speed = math.hypot(vx, vy)
        dx, dy = robot_xy[0] - px, robot_xy[1] - py
        norm = math.hypot(dx, dy)
        walking = speed > 0.2
        if walking:
            ux, uy = vx / speed, vy / speed
        elif norm < 1e-6:
            continue
        else:
            ux, uy = dx / norm, dy / norm
        rx, ry = wx - px, wy - py
        along = rx * ux + ry * uy
        across = np.abs(-rx * uy + ry * ux)
        need = keep_off if walking else keep_off + np.maximum(0.0, along - norm) * GIVE_WAY_FAN
        good &= np.hypot(rx, ry) >= min_distance
        # off the person's way: beside it, or behind the person (not reachable past them anyway)
        good &= (across >= need) | (along < -min_distance)
        if not walking and math.isfinite(hx) and math.isfinite(hy):  # and off the way they were walking
            good &= (np.abs(-rx * hy + ry * hx) >= keep_off) | (rx * hx + ry * hy < -min_distance)
    if not good.any():
        return None
    best = int(np.argmin(np.where(good, potential[rows, cols], np.inf)))
    return float(wx[best]), float(wy[best])
