"""Where the laser has seen free floor lately: an occupancy memory in the fixed frame (no ROS;
the beams are walked in a numba kernel).

Furniture legs, wall ends, door jambs, a plant's pot: the laser sees leg-sized things that never
move, and a tentative track fed by them (hopping from one chair leg to the next, or sliding along
a wall seen at a grazing angle) can seem to walk. A person walks through floor the laser saw free
before they stepped there. :class:`FreeSpace` keeps, per cell of a square window around the
robot, two counts that fade with a time constant: how often a beam passed through the cell, and
how often a beam ended in it. A point is *in free space* when its cell was passed through at least
``min_free`` times (faded) and was the end of a beam in at most ``max_occupied_ratio`` of those
observations: a static leg's cell ends beams in about half of them (or more), a cell a person
just stepped into had ended none before. Nor is a point free when a cell within
``neighbourhood`` of its own ended beams steadily (in ``steady_scans`` scans, faded, and in more
than ``max_occupied_ratio`` of its observations): a person who has stood still for a while,
whom the robot's odometry drift (it turned away and back) now puts a cell aside, onto floor the
laser saw free beside their legs, has not just come; a walker's stance lasts a few scans.

The window (``size`` x ``size`` m, cells of ``resolution``) follows the robot: it is re-centred
when the robot comes within a quarter of the window of its edge, keeping what overlaps.
"""

import math
from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class FreeSpaceParams:
    resolution: float = 0.05  # [m] cell side
    size: float = 16.0  # [m] side of the window around the robot
    fade: float = 20.0  # [s] time constant of the counts
    min_free: float = 2.0  # beams through a cell (faded) before it counts as seen free
    max_occupied_ratio: float = 0.4  # ... and the share of beams that ended in it at most
    margin: float = 0.10  # [m] a beam marks free space up to this short of its end
    max_range: float = 5.0  # [m] returns beyond are not used
    neighbourhood: int = 1  # cells: a point is not free when a cell this near ended beams steadily: ...
    steady_scans: float = 15.0  # ... in at least this many scans (faded), more than max_occupied_ratio of its beams

    def validate(self):
        for name in ("resolution", "size", "fade", "min_free", "margin", "max_range"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0 <= self.max_occupied_ratio < 1:
            raise ValueError(f"max_occupied_ratio must be within [0, 1), got {self.max_occupied_ratio}")
        if self.neighbourhood < 0 or not self.steady_scans > 0:
            raise ValueError("need neighbourhood >= 0 and steady_scans > 0")
        if self.size / self.resolution > 2000:
            raise ValueError("size / resolution must be at most 2000 cells a side")
        return self


class FreeSpace:
    def __init__(self, params=None):
        self.p = (params or FreeSpaceParams()).validate()
        self.n = round(self.p.size / self.p.resolution)
        self.free = np.zeros((self.n, self.n), np.float32)  # beams that passed through [faded count]
        self.occupied = np.zeros((self.n, self.n), np.float32)  # beams that ended here [faded count]
        self.hit_scans = np.zeros((self.n, self.n), np.float32)  # scans with a beam that ended here [faded]
        self.origin = None  # (x, y) [m] of the window's corner, in the fixed frame
        self.t = None  # [s] time of the last update
        self._stamp = np.zeros((self.n, self.n), np.int64)  # scan that last counted each cell free ...
        self._hit_stamp = np.zeros((self.n, self.n), np.int64)  # ... and as a beam's end
        self._scans = 0
        # compile (or load) the kernel now, not at the first scan
        _trace(self.free, self.occupied, self.hit_scans, self._stamp, self._hit_stamp, -1, 0.0, 0.0, np.zeros((1, 2)),
               np.zeros(1, bool), self.p.resolution, self.p.margin, self.p.max_range)

    def reset(self):
        self.free[:] = 0.0
        self.occupied[:] = 0.0
        self.hit_scans[:] = 0.0
        self.origin, self.t = None, None

    def _recentre(self, x, y):
        half = self.n * self.p.resolution / 2
        if self.origin is not None:
            ox, oy = self.origin
            quarter = half / 2
            if ox + quarter <= x <= ox + 2 * half - quarter and oy + quarter <= y <= oy + 2 * half - quarter:
                return
        new = (math.floor((x - half) / self.p.resolution) * self.p.resolution,
               math.floor((y - half) / self.p.resolution) * self.p.resolution)
        if self.origin is not None:
            dx = round((new[0] - self.origin[0]) / self.p.resolution)
            dy = round((new[1] - self.origin[1]) / self.p.resolution)
            for grid in (self.free, self.occupied, self.hit_scans):
                moved = np.zeros_like(grid)
                src = grid[max(dx, 0):self.n + min(dx, 0), max(dy, 0):self.n + min(dy, 0)]
                moved[max(-dx, 0):max(-dx, 0) + src.shape[0], max(-dy, 0):max(-dy, 0) + src.shape[1]] = src
                grid[:] = moved
        self.origin = new

    def _cells(self, xy):
        """(flat index, inside) of points [N, 2] in the fixed frame."""
        ij = np.floor((np.asarray(xy, float) - self.origin) / self.p.resolution).astype(np.int64)
        inside = (ij >= 0).all(axis=1) & (ij < self.n).all(axis=1)
        return np.where(inside, ij[:, 0] * self.n + ij[:, 1], 0), inside

    def in_free_space(self, xy):
        """Boolean [N]: the points [N, 2] (fixed frame) lie in cells seen free lately, and no cell
        within ``neighbourhood`` of theirs ended beams steadily: a person who stood still where the
        laser saw them (their legs' cells end its beams) and whom the robot's odometry now puts a
        cell aside, on floor it saw free beside their legs, is not a person who just came."""
        p = self.p
        xy = np.asarray(xy, float).reshape(-1, 2)
        if self.origin is None or len(xy) == 0:
            return np.zeros(len(xy), bool)
        idx, inside = self._cells(xy)
        free, occ = self.free.ravel()[idx], self.occupied.ravel()[idx]
        ok = inside & (free >= p.min_free) & (occ <= p.max_occupied_ratio * (free + occ))
        i, j = idx // self.n, idx % self.n
        k = p.neighbourhood
        for di in range(-k, k + 1):
            for dj in range(-k, k + 1):
                if di == 0 and dj == 0:
                    continue
                ni, nj = np.clip(i + di, 0, self.n - 1), np.clip(j + dj, 0, self.n - 1)
                f, o = self.free[ni, nj], self.occupied[ni, nj]
                ok &= ~((self.hit_scans[ni, nj] >= p.steady_scans) & (o > p.max_occupied_ratio * (f + o)))
        return ok

    def update(self, t, sensor_xy, ends_xy, hit):
        """One scan at time ``t`` [s]: beams from ``sensor_xy`` (2,) to ``ends_xy`` [N, 2] (fixed
        frame; NaN rows are skipped); ``hit`` [N] bool: the beam ended on something (False: no
        return within range, the beam only marks free space up to ``max_range``)."""
        p = self.p
        sensor = np.asarray(sensor_xy, float)
        self._recentre(*sensor)
        if self.t is not None and t > self.t:
            decay = np.float32(math.exp(-(t - self.t) / p.fade))
            self.free *= decay
            self.occupied *= decay
            self.hit_scans *= decay
        self.t = t if self.t is None else max(self.t, t)
        ends = np.asarray(ends_xy, float).reshape(-1, 2)
        hit = np.asarray(hit, bool).reshape(-1)
        ok = np.isfinite(ends).all(axis=1)
        if not ok.any():
            return
        self._scans += 1
        _trace(self.free, self.occupied, self.hit_scans, self._stamp, self._hit_stamp, self._scans,
               float(sensor[0] - self.origin[0]),
               float(sensor[1] - self.origin[1]), ends[ok] - np.asarray(self.origin), hit[ok], p.resolution,
               p.margin, p.max_range)


@numba.njit(cache=True)
def _trace(free, occupied, hit_scans, stamp, hit_stamp, scan, sx, sy, ends, hit, resolution, margin, max_range):
    """Walk each beam from the sensor (sx, sy) to its end (window coordinates [m]) in steps of a
    cell, counting each cell a beam passed through, once per scan, in ``free``; a beam that hit
    something stops ``margin`` short of its end and counts its end cell in ``occupied`` (and, once
    per scan, in ``hit_scans``)."""
    n = free.shape[0]
    for k in range(ends.shape[0]):
        dx, dy = ends[k, 0] - sx, ends[k, 1] - sy
        length = math.sqrt(dx * dx + dy * dy)
        if length < 1e-9:
            continue
        reach = min(length - margin if hit[k] else length, max_range)
        ux, uy = dx / length, dy / length
        steps = int(reach / resolution)
        for i in range(steps):
            d = i * resolution
            cx = math.floor((sx + ux * d) / resolution)
            cy = math.floor((sy + uy * d) / resolution)
            if cx < 0 or cy < 0 or cx >= n or cy >= n:
                break
            if stamp[cx, cy] != scan:
                stamp[cx, cy] = scan
                free[cx, cy] += 1.0
        if hit[k] and length <= max_range:
            cx = math.floor(ends[k, 0] / resolution)
            cy = math.floor(ends[k, 1] / resolution)
            if 0 <= cx < n and 0 <= cy < n:
                occupied[cx, cy] += 1.0
                if hit_stamp[cx, cy] != scan:
                    hit_stamp[cx, cy] = scan
                    hit_scans[cx, cy] += 1.0
