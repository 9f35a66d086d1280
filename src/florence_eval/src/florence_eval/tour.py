"""Evaluation helpers for amcl in the simulator, without ROS: a scripted tour of the apartment,
a waypoint follower, and the comparison of estimates with ground truth.

Used by the integration tests and bench/amcl.py.
"""

import math

import numpy as np

from florence_common import angles

# A loop through the shipped apartment (maps/apartment, map frame, metres), clear of furniture:
# living room -> corridor (door x 2.0..2.9) -> kitchen (door x 6.0..6.9) -> back to the living
# room through the opening at x = 5, y 1.5..3.0. One lap is about 18 m.
APARTMENT_LOOP = [(1.2, 4.8), (2.45, 4.9), (2.45, 6.15), (6.45, 6.15), (6.45, 4.6), (6.3, 2.25),
                  (4.2, 2.25), (1.0, 2.5)]
APARTMENT_START = (1.0, 2.5, 0.0)  # x [m], y [m], yaw [rad]


def path_length(start_xy, waypoints):
    points = np.vstack([start_xy, waypoints])
    return float(np.sum(np.hypot(*np.diff(points, axis=0).T)))


def tour(start_xy, loop, length):
    """Repeat the loop until the path is at least ``length`` [m] long; returns the waypoints."""
    lap = path_length(start_xy, loop)
    laps = max(1, math.ceil(length / lap))
    return [wp for _ in range(laps) for wp in loop]


def follow(pose, target, v_max=0.3, w_max=1.0, turn_in_place=0.35, tolerance=0.08):
    """Velocity (v [m/s], w [rad/s]) that drives a differential robot at pose (x, y, yaw) to target (x, y).

    Turns on the spot while the heading error exceeds ``turn_in_place`` [rad], else drives at v_max with a
    proportional heading correction. Returns (v, w, reached) with reached once within ``tolerance`` [m].
    """
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    dist = math.hypot(dx, dy)
    if dist < tolerance:
        return 0.0, 0.0, True
    err = float(angles.diff(math.atan2(dy, dx), pose[2]))
    w = max(-w_max, min(w_max, 2.0 * err))
    if abs(err) > turn_in_place:
        return 0.0, w, False
    v = min(v_max, 1.5 * dist) * math.cos(err)
    return max(0.05, v), w, False


def interpolate_poses(times, poses, query):
    """Poses [N, 3] at times [N] (increasing) interpolated at query times [M] (yaw unwrapped); NaN outside."""
    times, poses, query = np.asarray(times, float), np.asarray(poses, float), np.asarray(query, float)
    out = np.full((len(query), 3), np.nan)
    if len(times) < 2:
        return out
    inside = (query >= times[0]) & (query <= times[-1])
    yaw = np.unwrap(poses[:, 2])
    for i in range(2):
        out[inside, i] = np.interp(query[inside], times, poses[:, i])
    out[inside, 2] = np.interp(query[inside], times, yaw)
    return out


def estimate_errors(est_times, est_poses, truth_times, truth_poses):
    """Position error [m] and absolute yaw error [rad] of every estimate against interpolated truth."""
    truth = interpolate_poses(truth_times, truth_poses, est_times)
    est = np.asarray(est_poses, float).reshape(-1, 3)
    pos = np.hypot(est[:, 0] - truth[:, 0], est[:, 1] - truth[:, 1])
    yaw = np.abs(angles.diff(est[:, 2], truth[:, 2]))
    return pos, yaw


def rms(values):
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(values**2))) if values.size else float("nan")


def travelled(truth_poses):
    """Cumulative distance [m] along the truth poses [N, 3]."""
    poses = np.asarray(truth_poses, float)
    if len(poses) < 2:
        return np.zeros(len(poses))
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])


def convergence_index(pos_err, yaw_err, pos_tol=0.2, yaw_tol=0.1745, hold=5):
    """First index from which ``hold`` consecutive estimates are within tolerance (None if never).

    Default tolerances: 0.2 m and 0.1745 rad (10 deg).
    """
    ok = (np.asarray(pos_err) < pos_tol) & (np.asarray(yaw_err) < yaw_tol)
    run = 0
    for i, good in enumerate(ok):
        run = run + 1 if good else 0
        if run >= hold:
            return i - hold + 1
    return None


# ---- the mapping tour --------------------------------------------------------------------------------------------
# A tour of the whole apartment for building a map (maps/apartment, map frame, metres), the way the user manual
# says to drive (7.3): along the rooms, a full turn on the spot in each room. Every room; one loop: living room ->
# corridor -> (bedroom, bathroom: in and back out) -> kitchen -> through the opening back into the living room,
# where the tour began. Steps: ("go", x, y), ("spin",): a full turn counter-clockwise on the spot, ("clear", xmin,
# ymin, xmax, ymax): wait until nobody stands or walks in that box (the corridor is too narrow to pass a person,
# and the people of the apartment wait while the robot is in their way). About 47 m.
CORRIDOR = (-0.1, 5.5, 8.1, 6.8)  # the corridor's box [m]: x min, y min, x max, y max
MAPPING_TOUR = [
    ("spin",),
    ("go", 1.0, 4.3), ("spin",),
    ("go", 2.45, 4.9), ("clear", 0.0, 5.5, 2.75, 6.8),  # nobody west of the living room door
    ("go", 2.45, 6.15), ("go", 1.45, 6.15), ("go", 1.45, 7.5),  # the bedroom
    ("go", 3.0, 7.6), ("go", 4.6, 7.6), ("go", 4.6, 9.2), ("spin",), ("go", 4.6, 7.6), ("go", 1.45, 7.6),
    ("go", 1.45, 7.1), ("clear", 1.15, 5.5, 8.1, 6.8),  # nobody east of the bedroom door
    ("go", 1.45, 6.15), ("go", 6.6, 6.15), ("go", 6.6, 7.6),  # the bathroom
    ("go", 6.3, 8.5), ("spin",), ("go", 6.6, 7.5),
    ("go", 6.6, 7.1), ("clear", 4.0, 5.5, 8.1, 6.8),  # nobody in the corridor's east end
    ("go", 6.6, 6.15), ("go", 6.45, 5.0),  # the kitchen
    ("go", 6.45, 4.0), ("go", 6.3, 2.25), ("spin",), ("go", 6.0, 1.2), ("go", 6.3, 2.25),
    ("go", 4.2, 2.25), ("go", 1.0, 2.5), ("go", 1.6, 3.0),  # through the opening: the loop closes
]
MAPPING_START = APARTMENT_START


class TourDriver:
    """Drives a tour of ``steps`` (MAPPING_TOUR's kinds) from ground truth, as a person with a keyboard would:
    :meth:`command` gives (v [m/s], w [rad/s]) for the robot's true pose and the people's true positions and
    velocities.

    Near people it gives way. It stops while somebody stands or walks in its path, less than ``near`` [m] ahead
    and less than ``LATERAL`` m to either side; the people of florence_sim wait too while the robot is in their
    way, so after ``SIDESTEP_AFTER`` s it steps aside (``clearance(x, y)``, the distance [m] from a point to the
    nearest obstacle, picks a free spot; without it the driver only waits). A "clear" step waits until nobody
    is in its box or walking into it within ``lookahead`` [s]."""

    LATERAL = 0.45  # [m] a person this near the robot's line of travel is in its way (0.17 + 0.20 + a gap)
    SIDESTEP_AFTER = 2.0  # [s] blocked this long: step aside
    SIDESTEPS = ((0.0, 0.7), (0.0, -0.7), (0.4, 0.6), (0.4, -0.6), (0.8, 0.0))  # (away, aside) [m]
    HOLD = 8.0  # [s] at most, after a step aside, for the person to pass

    def __init__(self, steps, v_max=0.3, w_spin=0.8, near=0.9, clearance=None, lookahead=3.0):
        self.steps = list(steps)
        self.index = 0
        self.v_max, self.w_spin, self.near = v_max, w_spin, near
        self.clearance, self.lookahead = clearance, lookahead
        self.spun = None  # [rad] turned so far in a "spin" step
        self.last_yaw = None
        self.detour = []  # a step aside in progress: the free spot, then back where the robot left the tour
        self.holding = None  # [s] held at the spot so far
        self.blocked_for = 0.0  # [s]
        self.waited = 0.0  # [s] for people, over the tour
        self.sidesteps = 0

    @property
    def done(self):
        return self.index >= len(self.steps)

    def _in_the_way(self, pose, people):
        """The first person in the robot's way ((x, y, vx, vy)), or None."""
        c, s = math.cos(pose[2]), math.sin(pose[2])
        for person in people:
            dx, dy = person[0] - pose[0], person[1] - pose[1]
            ahead, left = c * dx + s * dy, -s * dx + c * dy
            if 0.0 < ahead < self.near and abs(left) < self.LATERAL:
                return person
        return None

    def _free_path(self, a, b, margin=0.3):
        return all(self.clearance(a[0] + k * (b[0] - a[0]), a[1] + k * (b[1] - a[1])) >= margin
                   for k in np.linspace(0.0, 1.0, 6))

    def _step_aside(self, pose, person):
        """A free spot off the line from the person to the robot (they wait because the robot stands on
        their way), or straight away from them; None if there is none."""
        ux, uy = pose[0] - person[0], pose[1] - person[1]
        norm = math.hypot(ux, uy) or 1.0
        ux, uy = ux / norm, uy / norm
        for away, aside in self.SIDESTEPS:
            spot = (pose[0] + away * ux - aside * uy, pose[1] + away * uy + aside * ux)
            if self._free_path(pose, spot):
                return spot
        return None

    def command(self, pose, people=(), dt=0.05):
        """(v, w) for the true ``pose`` (x, y, yaw) and ``people`` [(x, y) or (x, y, vx, vy), ...]; ``dt`` [s]
        since the last call. (0, 0) once the tour is done."""
        people = [tuple(p) + (0.0, 0.0) * (len(p) == 2) for p in people]
        while not self.done:
            step = self.steps[self.index]
            kind = step[0]
            if kind == "clear":
                la = self.lookahead
                if any(_inside(x, y, step[1:]) or _inside(x + la * vx, y + la * vy, step[1:])
                       for x, y, vx, vy in people):
                    self.waited += dt
                    return 0.0, 0.0
                self.index += 1
                continue
            if kind == "spin":
                if self.spun is None:
                    self.spun, self.last_yaw = 0.0, pose[2]
                self.spun += abs(angles.diff(pose[2], self.last_yaw))
                self.last_yaw = pose[2]
                if self.spun >= 2.0 * math.pi:
                    self.spun = None
                    self.index += 1
                    continue
                return 0.0, self.w_spin
            if self.holding is not None:  # stepped aside: let them pass
                near = any(math.hypot(x - pose[0], y - pose[1]) < self.near for x, y, _, _ in people)
                if near and self.holding < self.HOLD:
                    self.holding += dt
                    self.waited += dt
                    return 0.0, 0.0
                self.holding = None
            target = self.detour[0] if self.detour else step[1:3]
            v, w, reached = follow(pose, target, v_max=self.v_max)
            if reached:
                if self.detour:
                    self.detour.pop(0)
                    self.holding = 0.0 if len(self.detour) == 1 else None  # at the spot: let them pass
                else:
                    self.index += 1
                continue
            person = self._in_the_way(pose, people) if v > 0.0 else None
            if person is None:
                self.blocked_for = 0.0
                return v, w
            self.waited += dt
            self.blocked_for += dt
            if self.blocked_for > self.SIDESTEP_AFTER and self.clearance is not None and len(self.detour) <= 1:
                spot = self._step_aside(pose, person)
                if spot is not None:
                    back = self.detour[-1] if self.detour else tuple(pose[:2])
                    self.detour = [spot, back]
                    self.sidesteps += 1
                self.blocked_for = 0.0
            return 0.0, 0.0
        return 0.0, 0.0


def _inside(x, y, box):
    return box[0] <= x <= box[2] and box[1] <= y <= box[3]


def clearance_of(world_file=None, height=0.94):
    """``clearance(x, y)``: distance [m] from a point to the nearest obstacle of a florence_sim world (default:
    the apartment) between the floor and ``height`` [m] (the robot's: table tops count), as the person at the
    keyboard sees the room."""
    from florence_sim.world import load_world

    from florence_common.maps import map_file

    scene = load_world(str(world_file or map_file("apartment", "apartment.world.yaml"))).scene

    def clearance(x, y):
        return float(scene.clearance([[x, y]], z_max=height, z_min=0.0)[0][0])

    return clearance


def tour_length(start_xy, steps):
    """Length [m] of the "go" legs of a tour."""
    return path_length(start_xy, [s[1:3] for s in steps if s[0] == "go"])
