"""The published map: every scan of one trajectory ray-traced into hit and visit counts (numba, no ROS).

As slam_gmapping's updateMap: for each scan along the best particle's trajectory, each beam with a
reading up to maxRange is cut to maxUrange and walked from the laser's cell to its end cell with
Bresenham's line; every cell before the end counts a visit, and the end cell a hit and a visit when
the reading was shorter than maxUrange. A cell's occupancy is hits / visits: above occ_thresh it is
occupied (100), otherwise free (0); never visited, unknown (-1).

The counts are sums over scans, so adding the scans of a trajectory one update at a time gives the
same map as rebuilding it from scratch; :class:`GridSlam` rebuilds only when the best particle's
history changed.
"""

import math

import numba
import numpy as np

GROW_MARGIN = 20  # [cells] extra room when the counts grow (1 m at 0.05 m/cell)


class OccupancyCounts:
    """Hit and visit counts over a growing box of cells (cell (cx, cy) covers [cx delta, (cx + 1) delta) ...)."""

    def __init__(self, delta):
        self.delta = float(delta)
        self.hits = np.zeros((0, 0), np.int32)  # [row = y, column = x]
        self.visits = np.zeros((0, 0), np.int32)
        self.origin = np.zeros(2, np.int64)  # (cx, cy) of [0, 0]
        self.lo = None  # (cx, cy) bounds of every cell touched so far
        self.hi = None

    def cover(self, lo, hi):
        """Make room for cells lo..hi (cx, cy), inclusive."""
        lo, hi = np.asarray(lo, np.int64), np.asarray(hi, np.int64)
        rows, cols = self.hits.shape
        last = self.origin + np.array([cols - 1, rows - 1])
        if rows and (lo >= self.origin).all() and (hi <= last).all():
            return
        new_lo = lo - GROW_MARGIN if not rows else np.minimum(lo - GROW_MARGIN, self.origin)
        new_hi = hi + GROW_MARGIN if not rows else np.maximum(hi + GROW_MARGIN, last)
        shape = (int(new_hi[1] - new_lo[1] + 1), int(new_hi[0] - new_lo[0] + 1))
        hits, visits = np.zeros(shape, np.int32), np.zeros(shape, np.int32)
        if rows:
            r0, c0 = int(self.origin[1] - new_lo[1]), int(self.origin[0] - new_lo[0])
            hits[r0:r0 + rows, c0:c0 + cols] = self.hits
            visits[r0:r0 + rows, c0:c0 + cols] = self.visits
        self.hits, self.visits, self.origin = hits, visits, new_lo

    def add_scan(self, pose, laser, ranges, usable, max_range):
        """Ray-trace one scan taken at base pose (x, y, yaw) [m, rad]; ``ranges`` [B] [m] (inf: no reading)."""
        ranges = np.asarray(ranges, np.float64)
        x, y, th = (float(v) for v in pose)
        c, s = math.cos(th), math.sin(th)
        lox, loy = x + c * laser.x - s * laser.y, y + s * laser.x + c * laser.y
        use = ranges <= max_range
        if not use.any():
            return
        d = np.minimum(ranges[use], usable)
        ex = lox + d * (c * laser.cos[use] - s * laser.sin[use])
        ey = loy + d * (s * laser.cos[use] + c * laser.sin[use])
        lo = np.floor(np.array([min(ex.min(), lox), min(ey.min(), loy)]) / self.delta).astype(np.int64)
        hi = np.floor(np.array([max(ex.max(), lox), max(ey.max(), loy)]) / self.delta).astype(np.int64)
        self.cover(lo, hi)
        self.lo = lo if self.lo is None else np.minimum(self.lo, lo)
        self.hi = hi if self.hi is None else np.maximum(self.hi, hi)
        _trace(self.hits, self.visits, self.origin[0], self.origin[1], lox, loy, ex, ey, ranges[use] < usable,
               self.delta)

    def grid(self, occ_thresh, bounds=None):
        """(data [H, W] int8: -1 unknown, 0 free, 100 occupied; origin (x, y) [m] of its cell (0, 0)) over every
        cell touched, or over the box ``bounds`` = ((cx, cy) lo, hi) joined with it."""
        lo = self.lo if self.lo is not None else np.zeros(2, np.int64)
        hi = self.hi if self.hi is not None else np.zeros(2, np.int64)
        if bounds is not None:
            lo, hi = np.minimum(lo, bounds[0]), np.maximum(hi, bounds[1])
        shape = (int(hi[1] - lo[1] + 1), int(hi[0] - lo[0] + 1))
        data = np.full(shape, -1, np.int8)
        if self.lo is not None:
            r0, c0 = self.lo[1] - self.origin[1], self.lo[0] - self.origin[0]
            rows, cols = self.hi[1] - self.lo[1] + 1, self.hi[0] - self.lo[0] + 1
            hits = self.hits[r0:r0 + rows, c0:c0 + cols]
            visits = self.visits[r0:r0 + rows, c0:c0 + cols]
            block = np.full(hits.shape, -1, np.int8)
            seen = visits > 0
            block[seen] = np.where(hits[seen] > occ_thresh * visits[seen], 100, 0)
            dr, dc = self.lo[1] - lo[1], self.lo[0] - lo[0]
            data[dr:dr + rows, dc:dc + cols] = block
        return data, (float(lo[0] * self.delta), float(lo[1] * self.delta))


@numba.njit(cache=True, nogil=True)
def _trace(hits, visits, ox, oy, lox, loy, ex, ey, hit, delta):
    """Bresenham from the laser's cell to each end cell: visits before the end, a hit at the end if ``hit``."""
    x0 = math.floor(lox / delta) - ox
    y0 = math.floor(loy / delta) - oy
    for b in range(ex.shape[0]):
        x1 = math.floor(ex[b] / delta) - ox
        y1 = math.floor(ey[b] / delta) - oy
        dx = abs(x1 - x0)
        dy = -abs(y1 - y0)
        sx = 1 if x0 < x1 else -1
        sy = 1 if y0 < y1 else -1
        err = dx + dy
        x, y = x0, y0
        while x != x1 or y != y1:
            visits[y, x] += 1
            e2 = 2 * err
            if e2 >= dy:
                err += dy
                x += sx
            if e2 <= dx:
                err += dx
                y += sy
        if hit[b]:
            hits[y1, x1] += 1
            visits[y1, x1] += 1
