"""Where approach_me_map stops near a user, and the last half metre, without ROS (seed 3.10).

**Candidate poses.** On a circle of ``safe_distance`` (0.5 m, seed) around the user, every
``step`` degrees, facing the user. A candidate needs ``min_clearance`` [m] to every wall,
piece of furniture and unknown cell of the robot's map, and a straight line of sight to the user
that crosses no obstacle (no pose on the far side of a wall). Candidates are ranked
(:func:`rank`), best first:

- in front of the user: the angle at the user between the way they face and the line to the
  candidate, ``offset``, is what counts. The far side, behind them, costs most (Walters et al.
  2007: never from behind). Which way they face comes from the tracker (user_tracker_ni's
  ``facings``: a seated person's shins in front of the torso; the node leaves out a walker's,
  which is her way, and so what a jittering track reads as walking); while it does not say, the
  robot's side stands for the front (seed 3.10: "first on the robot's side"): a person faces,
  most likely, the robot that found them;
- when her facing is known, no pose nearer than ``knee_clearance`` to her knees, ``knee_reach``
  in front of her centre: at 0.5 m, head-on and 30 degrees off would put the robot's nose on a
  seated person's knees (florence_sim's seated body: shins 0.15-0.3 m in front of her centre, and
  the tracker's centre is pulled a little toward them), so the front-left / front-right poses
  start at 45 degrees;
- a seated person whose facing the tracker does not say (user_tracker_ni's ``seated``): beside
  her first, 90 degrees either way from the robot's side, and the robot's side and the far side
  like the far side of a known facing. The tracker reads a seated person's facing from her shins
  in front of her torso; where it sees none, the robot most likely looks at her back (or her shins
  hide behind a table), so its own side may be her back, and so may the far side: beside her is
  neither. From there the Kinect sees her shins, and once her facing is known a pose behind her
  ends the trial (make_plan ranked anew from her facing) (bench/locator.py seed 2: a user seated in
  the open, seen from behind, was approached at her back, 162 degrees from her front);
- front-left or front-right rather than head-on: an offset near ``preferred_offset`` (30 deg)
  costs least (Dautenhahn et al. 2006: seated people dislike a frontal approach and prefer the
  left or right, slightly the right; Walters et al. 2007: frontal is acceptable for a standing
  person in open space, so head-on is the next choice, where the room allows no other);
- the person's right (the robot's left as it faces them) by a little;
- more room around the pose, then the shorter way for the robot.

**Trials.** approach_me_map asks move_base's ``make_plan`` for the best candidates first, sends
the first with a path to move_base, and after a failure tries the next one at least
``trial_separation`` away in angle: at most 3 trials (seed 3.10). Candidates without a path are
skipped. A path that goes round the user within ``pass_distance`` of her by more than
``pass_sweep`` (:func:`swept_near`) is taken only when no other candidate has a path, even one
behind her, and then the one whose path goes least round her: move_base's local planner keeps
0.6 m from a person (min_person_distance) and cannot follow a plan that goes round her nearer,
so the robot stalls on the way, at her back. (Taken before the poses behind her, gotoUser to
test_locator_sim's seated user, in the living room's corner between the coffee table and a
chair, took 106 and 132 s and once ABORTED after 200 s; with the pose behind her, 14 s.) So is a
path that passes nearer than ``stranger_distance`` to somebody else standing still
(:func:`strangers`, :func:`least_distance`), for the same reason: the robot would wait for them
until the trial's time ran out. Of such fallbacks, one past nobody comes first. (make demo: her
front, round the dining table, passed 0.55 m from the visitor standing by it; the robot waited
there 45 s, then went to her back.) So is a detour, a path longer than the straight line by more
than ``max_detour`` (:func:`judge_way`, which orders the fallbacks: past nobody, no detour, least
round her): the ways to the demo's seated user's front went round the dining area (7-13 m for
2 m) or between her and the table (2.4-3.3 m) as her track came and went in the global costmap,
and the robot circled between them until the trial's time ran out. Somebody the tracker does
not show when the poses are ranked (out of the Kinect's view) counts once move_base has waited
``stranger_wait`` for them (:class:`StrangerWait`), or once the robot sees them standing that
near what is left of its way (:func:`in_the_way`): that trial ends, and the next ones keep clear
of where they stand.

**A stalled trial** (:class:`Stall`). Near a seated person's body move_base may stop short of the
pose and never finish: its local planner refuses to turn the footprint's nose into her costs
(the last 0.2-0.4 rad of yaw) and waits until the trial's timeout. A robot that has not moved
for ``stall_timeout`` within ``stall_radius`` of the pose ends move_base's goal and does the
last half metre from there; so does one that has been within ``stall_radius`` for ``stall_linger``
however it moved (turning to and fro beside a chair), unless it is behind her (then the next trial).

A trial whose move_base goal failed ends with the last half metre from where the robot stands
when that is within 0.6 m of the pose's distance from the user, but not from behind her
(:func:`behind`) unless it is the last trial: the next trial tries another pose instead.

**The last half metre** (:class:`Align`). move_base stops within its xy_goal_tolerance (0.25 m)
of the goal, too coarse for 0.5 m from a person. From where it stopped, the robot turns on the
spot to face the user, drives straight toward or away from them to ``safe_distance`` (slowly;
forward only while the laser shows ``front_margin`` free beyond its nose, backward only as far as
the map is free behind it), and turns to face them again. Closed on odometry.
"""

import math
from dataclasses import dataclass

import numpy as np

from florence_common import angles
from florence_common.grid import Grid


@dataclass(frozen=True)
class ApproachParams:
    safe_distance: float = 0.5  # [m] centre of the robot to centre of the user (seed DEFAULT_SAFE_DISTANCE)
    step: float = math.radians(15.0)  # [rad] between candidate angles around the user
    preferred_offset: float = math.radians(30.0)  # [rad] front-left / front-right
    # [rad] beyond this offset: the far side, behind her (not wider: the tracker's facing of a seated person
    # was 15-35 deg off, a dining chair's legs beside her counted as her shins; a pose 105 deg from it ended 152 deg
    # from her true facing in test_locator_sim's corner. Without the chair's legs, 0-8 deg there: 29 Nov)
    side_limit: float = math.radians(90.0)
    min_clearance: float = 0.25  # [m] from a candidate's centre to walls and furniture on the map
    user_radius: float = 0.3  # [m] obstacles this near the user are the user's seat (sofa, chair, bed)
    trial_separation: float = math.radians(40.0)  # [rad] a new trial differs this much from the tried ones
    right_bonus: float = 0.05  # cost taken off the person's right side
    knee_reach: float = 0.3  # [m] a seated person's knees this far in front of her centre (her facing known) ...
    knee_clearance: float = 0.35  # [m] ... and no pose's centre nearer them than this (the robot's radius + 0.17)


@dataclass(frozen=True)
class Candidate:
    x: float  # [m] map
    y: float
    yaw: float  # [rad] facing the user
    angle: float  # [rad] direction from the user to the pose
    offset: float  # [rad] angle at the user from the way they face, counter-clockwise positive
    clearance: float  # [m] to the nearest obstacle of the map
    cost: float


class ObstacleGrid(Grid):
    """The robot's map as obstacles (florence_common.grid.Grid: occupancy >= ``occupied`` or unknown)."""

    def line_free(self, a, b, skip_near_b=0.0):
        """Whether the segment a -> b crosses no obstacle, ignoring its last ``skip_near_b`` [m]."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        length = float(np.hypot(*(b - a)))
        usable = length - skip_near_b
        if usable <= 0:
            return True
        return bool(self.line_of_sight([a], a + (b - a) * (usable / length))[0])

    def free_within(self, xy, radius):
        """Whether a disc of ``radius`` [m] at each of the points [N, 2] is free (bool [N])."""
        return self.clearance_at(xy) >= radius


def reaimed(target, shift, grid, min_clearance):
    """The pose ``target`` (x, y) [m] moved by ``shift`` (dx, dy) [m] with the user's tracked place, or
    None when the map ``grid`` (an ObstacleGrid; None: no map) has furniture within ``min_clearance``
    [m] of it there: a pose beside a table, moved with her track's jitter, fell within the table's
    inscribed ring and move_base ran its recoveries ("the goal is in an obstacle")."""
    moved = (float(target[0] + shift[0]), float(target[1] + shift[1]))
    if grid is not None and not grid.free_within([moved], min_clearance)[0]:
        return None
    return moved


def rank(user, robot, p, grid=None, exclude=(), facing=None, seated=False, not_behind=False):
    """Candidate poses around ``user`` (x, y) [m] for a robot at ``robot`` (x, y) [m], best first
    (module docstring). ``grid``: an ObstacleGrid (None: every pose is free); ``exclude``: angles
    [rad] around the user already tried (candidates nearer than p.trial_separation are left out);
    ``facing`` [rad]: which way the user faces, in the frame of ``user`` (None or not finite:
    unknown, the robot's side is the front, or, ``seated``, beside her comes first).
    ``not_behind``, with her facing known: her front was not reached in time; only the poses not
    behind her (within ``side_limit`` of her facing), all alike but for their room and the robot's
    way to them (the nearest first)."""
    ux, uy = user
    known = facing is not None and math.isfinite(facing)
    front = facing if known else math.atan2(robot[1] - uy, robot[0] - ux)
    n = max(4, round(2 * math.pi / p.step))
    offsets = np.array([angles.wrap(k * 2 * math.pi / n) for k in range(n)])
    directions = front + offsets
    xy = np.column_stack([ux + p.safe_distance * np.cos(directions), uy + p.safe_distance * np.sin(directions)])
    clearance = np.full(n, math.inf) if grid is None else grid.clearance_at(xy)
    if known:  # her knees (seated) or her way (walking) in front of her: not where the robot stands
        knees = np.hypot(xy[:, 0] - ux - p.knee_reach * math.cos(front), xy[:, 1] - uy - p.knee_reach * math.sin(front))
        clearance = np.where(knees < p.knee_clearance, -math.inf, clearance)
    out = []
    for k in range(n):
        direction = float(angles.wrap(directions[k]))
        if any(abs(angles.diff(direction, e)) < p.trial_separation for e in exclude):
            continue
        if clearance[k] < p.min_clearance:
            continue
        if grid is not None and not grid.line_free(xy[k], (ux, uy), skip_near_b=p.user_radius):
            continue
        off = float(offsets[k])
        if known and not_behind:
            if abs(off) > p.side_limit:
                continue
            cost = 0.0
        else:
            cost = _beside_cost(abs(off), p) if seated and not known else _angle_cost(abs(off), p)
        cost += 0.2 * max(0.0, 0.45 - min(clearance[k], 0.45)) / 0.2
        if off < 0:  # clockwise from the way the person faces: their right
            cost -= p.right_bonus
        cost += 0.1 * float(np.hypot(xy[k, 0] - robot[0], xy[k, 1] - robot[1]))
        out.append(Candidate(float(xy[k, 0]), float(xy[k, 1]), float(angles.wrap(direction + math.pi)), direction,
                             off, float(clearance[k]), float(cost)))
    out.sort(key=lambda c: c.cost)
    return out


def still_facings(facings, speeds, max_speed):
    """The tracker's facings [rad] (N,) with NaN where a track moves at ``max_speed`` [m/s] or faster
    (a walker's facing is her way; a still person's track jittering reads the same) or its speed
    is not finite."""
    facings = np.array(facings, dtype=float).reshape(-1)
    speeds = np.asarray(speeds, dtype=float).reshape(-1)
    facings[~(speeds < max_speed)] = np.nan
    return facings


def nearest_track(user, xy, gate):
    """Index of the track of ``xy`` [N, 2] (map) nearest ``user`` (x, y) within ``gate`` [m], or None."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    d = np.hypot(xy[:, 0] - user[0], xy[:, 1] - user[1])
    d[~np.isfinite(d)] = np.inf
    if not len(d) or d.min() > gate:
        return None
    return int(np.argmin(d))


def swept_near(path_xy, user, radius):
    """How far [rad] a path (N, 2) [m] goes round ``user`` (x, y) within ``radius`` [m] of her: the
    span of the bearings from her of its points nearer than ``radius``, unwrapped along the path
    (0 when none is that near)."""
    xy = np.asarray(path_xy, dtype=float).reshape(-1, 2)
    if not len(xy):
        return 0.0
    bearing = np.unwrap(np.arctan2(xy[:, 1] - user[1], xy[:, 0] - user[0]))
    near = np.hypot(xy[:, 0] - user[0], xy[:, 1] - user[1]) < radius
    return float(np.ptp(bearing[near])) if near.any() else 0.0


def strangers(xy, speeds, user, gate, max_speed):
    """The tracked people (``xy`` (N, 2) [m], ``speeds`` (N,) [m/s]) other than the user (the track
    nearest ``user`` (x, y) within ``gate`` [m], :func:`nearest_track`) who stand still (slower than
    ``max_speed``; a walker will have moved on): (S, 2) [m]."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    speeds = np.asarray(speeds, dtype=float).reshape(-1)
    keep = np.isfinite(xy).all(axis=1) & (speeds < max_speed)
    k = nearest_track(user, xy, gate)
    if k is not None:
        keep[k] = False
    return xy[keep]


def _from_path(xy, points):
    """Each point's least distance [m] to the path ``xy`` (N >= 1, 2) [m]: (S,)."""
    return np.hypot(xy[:, None, 0] - points[None, :, 0], xy[:, None, 1] - points[None, :, 1]).min(axis=0)


def least_distance(path_xy, points):
    """The least distance [m] between a path (N, 2) [m] and ``points`` (S, 2) [m] (inf: none)."""
    xy = np.asarray(path_xy, dtype=float).reshape(-1, 2)
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(xy) or not len(points):
        return math.inf
    return float(_from_path(xy, points).min())


def path_length(path_xy):
    """Length [m] of a path (N, 2) [m]: the way a plan makes the robot drive (0 for under two points)."""
    xy = np.asarray(path_xy, dtype=float).reshape(-1, 2)
    return float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(xy) > 1 else 0.0


def judge_way(path_xy, start, pose, user, others, pass_distance, pass_sweep, stranger_distance, max_detour):
    """Whether a make_plan path (N, 2) [m] from ``start`` (x, y) to ``pose`` (x, y) suits an approach
    of the user at ``user`` (x, y), with ``others`` (S, 2) the other people standing: (rank, why).
    ``rank`` = (passes near somebody else, is a detour, angle [rad] it goes round her within
    ``pass_distance``); the path is taken when it is (False, False, <= ``pass_sweep`` [rad]), else
    the least rank is the fallback. ``why``: what is wrong with it ('' when nothing)."""
    sweep = swept_near(path_xy, user, pass_distance)
    near = least_distance(path_xy, others)
    length, straight = path_length(path_xy), math.dist(start[:2], pose[:2])
    rank = (near < stranger_distance, length - straight > max_detour, sweep)
    if rank[0]:
        return rank, f"passes {near:.2f} m from somebody else"
    if rank[1]:
        return rank, f"is {length:.1f} m for {straight:.1f} m"
    if sweep > pass_sweep:
        return rank, f"goes {math.degrees(sweep):.0f} deg round her"
    return rank, ""


class StrangerWait:
    """Whether move_base has waited ``wait`` [s] for somebody other than the user (module
    docstring): its waiting_for ((x, y) [m], time received [s]), sent at most twice a second while
    it waits, counts while at most ``fresh`` [s] old and farther than ``gate`` [m] from the user."""

    def __init__(self, wait, gate, fresh=1.0):
        self.wait, self.gate, self.fresh = float(wait), float(gate), float(fresh)
        self.since = None  # [s] since when move_base waits for somebody else

    def update(self, now, user, waiting_for):
        """(x, y) [m] of the stranger once waited for ``wait``, else None; ``user`` (x, y) [m]."""
        if waiting_for is None or now - waiting_for[1] > self.fresh or \
                math.hypot(waiting_for[0][0] - user[0], waiting_for[0][1] - user[1]) <= self.gate:
            self.since = None
            return None
        self.since = now if self.since is None else self.since
        return tuple(waiting_for[0]) if now - self.since >= self.wait else None


def in_the_way(path_xy, robot, points, radius):
    """The ``points`` (S, 2) [m] nearer than ``radius`` [m] to what is left of a path (N, 2) [m] for a
    robot at ``robot`` (x, y) [m]: from the path's point nearest it on. Returns (S', 2)."""
    xy = np.asarray(path_xy, dtype=float).reshape(-1, 2)
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(xy) or not len(points):
        return points[:0]
    rest = xy[int(np.argmin(np.hypot(xy[:, 0] - robot[0], xy[:, 1] - robot[1]))):]
    return points[_from_path(rest, points) < radius]


def behind(user, robot, facing, limit):
    """Whether ``robot`` (x, y) [m] stands behind a user at ``user`` (x, y) who faces ``facing``
    [rad]: more than ``limit`` [rad] (ApproachParams.side_limit) from the way she faces (None or
    NaN: unknown, never behind)."""
    if facing is None or not math.isfinite(facing):
        return False
    return abs(angles.diff(math.atan2(robot[1] - user[1], robot[0] - user[0]), facing)) > limit


def _angle_cost(offset, p):
    """Cost of an approach ``offset`` [rad] (absolute) from the way the user faces."""
    front = p.preferred_offset
    if offset <= 2 * front:  # front-left / front-right best, head-on next
        return 0.5 * abs(offset - front) / front
    if offset <= p.side_limit:  # beside the person
        return 0.5 + (offset - 2 * front) / max(p.side_limit - 2 * front, 1e-6)
    return 3.0 + (offset - p.side_limit) / math.pi  # the far side: only when nothing else is free


def _beside_cost(offset, p):
    """Cost of a pose ``offset`` [rad] (absolute) from the robot's side of a seated user whose facing is
    unknown: beside her (90 deg) best, within ``preferred_offset`` * 1.5 of it; nearer the robot's side or
    the far side, either of which may be her back, as the far side of a known facing."""
    side, reach = abs(offset - math.pi / 2), 1.5 * p.preferred_offset
    if side <= reach:
        return 0.5 * side / reach
    return 3.0 + (side - reach) / math.pi


# --- the last half metre -------------------------------------------------------------------------------------------
class Stall:
    """Whether a robot driven by move_base stopped near its goal (module docstring): ``radius`` [m]
    around the goal, still (within ``moved`` [m] and ``turned`` [rad] of where it stood) for
    ``timeout`` [s], or within ``radius`` for ``linger`` [s] however it moved (turning to and fro,
    replanning, backing off and coming on again: make demo's robot spent some 20 s so beside a seated
    user's chair, its goal in her costs, until the trial's deadline sent it round to her back)."""

    def __init__(self, radius, timeout, moved=0.05, turned=0.1, linger=math.inf):
        self.radius, self.timeout, self.moved, self.turned = float(radius), float(timeout), moved, turned
        self.linger = float(linger)
        self.anchor = None  # (x, y, yaw, t): where and since when the robot stands
        self.entered = None  # [s] since when the robot has been within radius
        self.why = ""  # what the stall was: standing still, or lingering

    def update(self, t, robot, goal):
        """``robot`` (x, y, yaw) and ``goal`` (x, y) at time ``t`` [s]: True once stalled."""
        x, y, yaw = robot
        if math.hypot(x - goal[0], y - goal[1]) > self.radius:
            self.anchor = self.entered = None
            return False
        if self.entered is None:
            self.entered = t
        if t - self.entered >= self.linger:
            self.why = f"within {self.radius:.2f} m of the pose for {self.linger:.0f} s"
            return True
        a = self.anchor
        if a is None or math.hypot(x - a[0], y - a[1]) > self.moved or abs(angles.diff(yaw, a[2])) > self.turned:
            self.anchor = (x, y, yaw, t)
            return False
        self.why = f"stood still for {self.timeout:.0f} s"
        return t - a[3] >= self.timeout


@dataclass(frozen=True)
class AlignParams:
    safe_distance: float = 0.5  # [m]
    max_speed: float = 0.15  # [m/s]
    min_speed: float = 0.04  # [m/s]
    accel: float = 0.3  # [m/s^2] braking of the straight move
    max_turn: float = 0.6  # [rad/s]
    min_turn: float = 0.15  # [rad/s]
    turn_decel: float = 0.8  # [rad/s^2]
    angle_tolerance: float = math.radians(2.0)  # [rad] facing the user this well ends a turn ...
    angle_overshoot: float = math.radians(6.0)  # [rad] ... and so does having turned past by at most this
    distance_tolerance: float = 0.03  # [m] the straight move ends this near safe_distance ...
    distance_overshoot: float = 0.06  # [m] ... or having driven past it by at most this
    front_margin: float = 0.05  # [m] free space kept ahead of the robot's nose (laser)
    back_margin: float = 0.05  # [m] free space kept behind the robot (map)
    still_rate: float = 0.05  # [rad/s] and [m/s]: at rest below this
    lead: float = 0.3  # [s] the braking looks this far ahead at the measured speed (late commands)
    accept_distance: float = 0.1  # [m] success: |distance - safe_distance| within this ...
    accept_angle: float = math.radians(10.0)  # [rad] ... and facing the user within this
    blocked_accept: float = 0.15  # [m] success too: blocked ahead (the user's knees) at most this beyond safe_distance
    held_time: float = 1.5  # [s] a straight move at rest this long (the collision monitor holds it) is blocked
    timeout: float = 25.0  # [s]


@dataclass
class AlignStep:
    v: float = 0.0  # [m/s]
    w: float = 0.0  # [rad/s]
    done: bool = False
    ok: bool = False
    why: str = ""


def _profile(remaining, top, bottom, decel):
    return math.copysign(min(top, max(bottom, math.sqrt(2.0 * decel * abs(remaining)))), remaining)


class Align:
    """Turn to face the user, drive to safe_distance, face them again; stepped at the control rate
    with the robot's odometry pose and the user's position in the same frame."""

    def __init__(self, p, now):
        self.p = p
        self.phase = "turn"
        self.started = now
        self.blocked = ""
        self.sign = 0.0  # direction of the turn or move under way (crossing the target ends it)
        self.held_since = None  # [s] since when the straight move has been commanded but at rest

    @staticmethod
    def geometry(robot, user):
        """(distance [m], facing error [rad]) of a robot pose (x, y, yaw) to a user (x, y)."""
        dx, dy = user[0] - robot[0], user[1] - robot[1]
        return math.hypot(dx, dy), angles.diff(math.atan2(dy, dx), robot[2])

    def update(self, now, robot, speed, user, front_free=math.inf, back_free=math.inf):
        """``robot`` (x, y, yaw) and ``speed`` (v [m/s], w [rad/s]) from odometry; ``user`` (x, y) in
        the odometry frame; ``front_free`` [m]: free space ahead of the nose (laser); ``back_free``
        [m]: free space behind the robot (map)."""
        p = self.p
        distance, error = self.geometry(robot, user)
        at_rest = abs(speed[0]) < p.still_rate and abs(speed[1]) < p.still_rate
        if now - self.started > p.timeout:
            return self._finish(distance, error, f"alignment took longer than {p.timeout:.0f} s")
        if self.phase in ("turn", "turn_again"):
            crossed = self.sign * error < 0 and abs(error) <= p.angle_overshoot  # turned past: no way back
            if abs(error) > p.angle_tolerance and not crossed:
                self.sign = math.copysign(1.0, error)
                ahead = error - speed[1] * p.lead  # where the turn will be when a command takes effect
                w = _profile(ahead, p.max_turn, p.min_turn, p.turn_decel) if ahead * error > 0 else 0.0
                return AlignStep(w=w)
            if not at_rest:
                return AlignStep()
            if self.phase == "turn_again":
                return self._finish(distance, error)
            self.phase, self.sign = "move", 0.0
        if self.phase == "move":
            remaining = distance - p.safe_distance
            free = front_free - p.front_margin if remaining > 0 else back_free - p.back_margin
            crossed = self.sign * remaining < 0 and abs(remaining) <= p.distance_overshoot
            # held: commanded, yet at rest for held_time (the collision monitor stops what the laser's
            # free space here allows: make demo's robot stood 25 s so in front of a seated user, ABORTED)
            still = abs(speed[0]) < p.still_rate  # (the monitor lets turning on the spot through)
            self.held_since = (self.held_since if self.held_since is not None else now) if still else None
            held = self.sign != 0.0 and self.held_since is not None and now - self.held_since >= p.held_time
            if abs(remaining) <= p.distance_tolerance or free <= 0.0 or crossed or held:
                if (free <= 0.0 or held) and abs(remaining) > p.distance_tolerance:
                    way = "blocked ahead" if remaining > 0 else "no room behind"
                    self.blocked = way + (" (held at rest: the collision monitor?)" if held and free > 0.0 else "")
                self.phase, self.sign = "turn_again", 0.0
                return AlignStep()
            self.sign = math.copysign(1.0, remaining)
            go = math.copysign(min(abs(remaining), max(free, 0.0)), remaining)
            ahead = go - speed[0] * p.lead  # the measured speed carries the robot on before a command acts
            v = _profile(ahead, p.max_speed, p.min_speed, p.accel) if ahead * go > 0 else 0.0
            w = max(-p.max_turn, min(p.max_turn, 1.5 * error))
            return AlignStep(v=v, w=w)
        raise AssertionError(f"unknown phase {self.phase}")

    def _finish(self, distance, error, why=""):
        p = self.p
        near = abs(distance - p.safe_distance) <= p.accept_distance
        # a seated user's knees reach 0.3 m toward the robot: at 0.5 m the nose would be on them; the
        # laser stops it short, as near as it goes, and that is where a polite robot stands
        as_near = self.blocked.startswith("blocked ahead") and 0.0 < distance - p.safe_distance <= p.blocked_accept
        ok = not why and (near or as_near) and abs(error) <= p.accept_angle
        text = why or (f"{distance:.2f} m from the user, facing them within {math.degrees(abs(error)):.0f} deg"
                       + (f" ({self.blocked})" if self.blocked else ""))
        return AlignStep(done=True, ok=ok, why=text)
