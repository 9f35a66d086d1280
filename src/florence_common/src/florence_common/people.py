"""The person a behaviour attends to, among the people a tracker reports (ROS-free).

The behaviours (follow_me, approach_me) are given a point near a person; they pick the tracked
person nearest to it (:func:`nearest`) and keep that person by the tracker's persistent id
(:class:`AttendedPerson`). Positions are in one fixed frame (the tracker's, odom by default) [m],
times in seconds.

Ids change in two ways a behaviour must ride through: a person the laser alone confirmed gets a
*provisional* id that the tracker replaces by the known one once the Kinect sees their colours;
and a person lost and found again may come back under a new track. A new id is taken for the
attended person only when it appears near where they were expected and was never seen at the same
time as them (then it is somebody else).
"""

import math
from dataclasses import dataclass, field

import numpy as np


def nearest(points, target, radius):
    """Index of the row of ``points`` [N, 2] nearest to ``target`` (x, y) within ``radius`` [m] (NaN
    rows never), or None; and the distance [m] to the nearest row (inf when there is none)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(pts) == 0:
        return None, math.inf
    d = np.hypot(pts[:, 0] - target[0], pts[:, 1] - target[1])
    d = np.where(np.isfinite(d), d, np.inf)
    i = int(np.argmin(d))
    return (i if d[i] <= radius else None), float(d[i])


def acquire(ids, xy, velocities, t, point, radius, **kwargs):
    """(AttendedPerson, None) for the tracked person nearest to ``point`` (x, y) within ``radius``
    [m], or (None, why not). ``kwargs`` go to AttendedPerson."""
    ids = list(ids)
    if not ids:
        return None, "nobody is tracked"
    k, gap = nearest(xy, point, radius)
    if k is None:
        return None, (f"no tracked person within {radius:.2f} m of ({point[0]:.2f}, {point[1]:.2f}): the nearest of "
                      f"{len(ids)} is {gap:.2f} m from it")
    v = np.asarray(velocities, dtype=float).reshape(-1, 2)[k]
    person = AttendedPerson(int(ids[k]), tuple(np.asarray(xy, dtype=float)[k]),
                            tuple(v) if np.all(np.isfinite(v)) else (0.0, 0.0), t, **kwargs)
    person.others.update(int(i) for i in ids if int(i) != person.pid)
    return person, None


@dataclass
class AttendedPerson:
    """One tracked person, kept by persistent id through the tracker's reports.

    ``reacquire_radius`` [m]: how near where the person was expected a new id must appear to be
    taken for them; ``max_extrapolation`` [s]: how long their last velocity carries the expected
    position once they are unseen; ``reacquire_growth`` [m/s]: how fast that radius grows once the
    velocity no longer carries the expected position (how far the person may have walked on unseen:
    a person who turned behind a wall is seen again well beyond the 1 s they are carried), up to
    ``reacquire_max_radius`` [m]. An id seen beside theirs (:attr:`others`) is never taken."""

    pid: int
    xy: tuple
    velocity: tuple = (0.0, 0.0)
    seen_at: float = 0.0
    reacquire_radius: float = 0.6
    max_extrapolation: float = 1.0
    reacquire_growth: float = 0.0
    reacquire_max_radius: float = 2.0
    own_ids: set = field(default_factory=set)  # every id this person went by
    others: set = field(default_factory=set)  # ids seen at the same time as them: other people
    switches: list = field(default_factory=list)  # (t, old id, new id)

    def __post_init__(self):
        self.xy = (float(self.xy[0]), float(self.xy[1]))
        self.velocity = (float(self.velocity[0]), float(self.velocity[1]))
        self.own_ids.add(int(self.pid))

    def expected(self, t):
        """Where the person is expected at ``t`` [s]: the last position moved on by the last
        velocity for at most ``max_extrapolation`` s."""
        dt = min(max(t - self.seen_at, 0.0), self.max_extrapolation)
        return self.xy[0] + self.velocity[0] * dt, self.xy[1] + self.velocity[1] * dt

    def search_radius(self, t):
        """How near where they are expected [m] a new id is taken for them at ``t`` [s]."""
        walked = self.reacquire_growth * max(self.unseen_for(t) - self.max_extrapolation, 0.0)
        return max(self.reacquire_radius, min(self.reacquire_radius + walked, self.reacquire_max_radius))

    def unseen_for(self, t):
        return max(t - self.seen_at, 0.0)

    def confirm(self, xy, t):
        """Another sensor's sighting of this person at ``xy`` at ``t`` [s] (a leg pair close up): their
        place, seen now; the velocity is kept."""
        self.xy = (float(xy[0]), float(xy[1]))
        self.seen_at = max(self.seen_at, t)

    def update(self, ids, xy, velocities, t):
        """A tracker report at ``t`` [s]: ids [N], positions [N, 2], velocities [N, 2] (NaN rows are
        skipped). Returns True when the person is in it (under their id or a new one taken for them)."""
        ids = [int(i) for i in ids]
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        vel = np.asarray(velocities, dtype=float).reshape(-1, 2)
        ok = np.all(np.isfinite(xy), axis=1)
        index = {pid: k for k, pid in enumerate(ids) if ok[k]}
        found = index.get(self.pid)
        if found is None:  # known under another id of theirs (a provisional id re-identified)
            found = next((index[i] for i in self.own_ids if i in index), None)
        if found is None:
            candidates = [k for pid, k in index.items() if pid not in self.others]
            if candidates:
                k, _ = nearest(xy[candidates], self.expected(t), self.search_radius(t))
                found = None if k is None else candidates[k]
        if found is None:
            return False
        new = ids[found]
        if new != self.pid:
            self.switches.append((t, self.pid, new))
            self.pid = new
            self.own_ids.add(new)
        self.others.update(pid for pid in index if pid not in self.own_ids)
        self.xy = (float(xy[found, 0]), float(xy[found, 1]))
        v = vel[found] if found < len(vel) and np.all(np.isfinite(vel[found])) else (0.0, 0.0)
        self.velocity = (float(v[0]), float(v[1]))
        self.seen_at = t
        return True
