"""Occupancy grids in the map frame (map_server's values: 0..100 occupancy, -1 unknown; row 0 at
the origin): which cell a point falls in, whether it is an obstacle, how far the nearest one is.

    grid = Grid(data, origin=(x0, y0, yaw0), resolution=0.05)
    grid.blocked_at([[1.0, 2.0]])      # [True] inside an occupied or unknown cell, or off the grid
    grid.clearance_at([[1.0, 2.0]])    # [m] from the cell's centre to the nearest blocked cell
    grid.line_of_sight([[0.0, 0.0]], (1.0, 2.0))  # [True] the segment crosses no blocked cell
    grid.sight_matrix(starts, ends)    # [N, M] the same for every pair (a numba kernel)
    grid.with_obstacles(keepout)       # this grid with another's blocked cells added
"""

import math

import numpy as np
from scipy import ndimage

from florence_common.jit import lazy_njit


def _sight_matrix(blocked, ox, oy, c, s, resolution, starts, ends, skip_end, max_length, step):
    h, w = blocked.shape
    out = np.zeros((starts.shape[0], ends.shape[0]), dtype=np.bool_)
    for i in range(starts.shape[0]):
        ax, ay = starts[i, 0], starts[i, 1]
        for j in range(ends.shape[0]):
            dx, dy = ends[j, 0] - ax, ends[j, 1] - ay
            length = math.sqrt(dx * dx + dy * dy)
            if not math.isfinite(length) or length > max_length:
                continue  # (not seen: a NaN point, or farther than max_length)
            usable = length - skip_end
            clear = True
            if usable > 0.0 or skip_end <= 0.0:  # (a skipped end that covers the whole segment: nothing to see)
                frac = usable / length if length > 0.0 else 0.0
                n = max(2, math.ceil(max(usable, 0.0) / step) + 1)
                for k in range(n):
                    t = frac * k / (n - 1)
                    px, py = ax + t * dx - ox, ay + t * dy - oy
                    u = math.floor((c * px + s * py) / resolution)
                    v = math.floor((-s * px + c * py) / resolution)
                    if v < 0 or v >= h or u < 0 or u >= w or blocked[int(v), int(u)]:
                        clear = False
                        break
            out[i, j] = clear
    return out


_SIGHT_MATRIX = lazy_njit(_sight_matrix)  # importing numba costs the many users of this module time


class Grid:
    """``data`` (H, W) ints; ``origin`` (x [m], y [m], yaw [rad]) of cell (0, 0)'s corner;
    ``resolution`` [m/cell]; cells with occupancy >= ``occupied`` or unknown (< 0) are blocked."""

    def __init__(self, data, origin, resolution, occupied=65):
        self.data = np.asarray(data)
        self.origin = tuple(float(v) for v in origin)
        self.resolution = float(resolution)
        self.occupied = occupied
        self.blocked = (self.data >= occupied) | (self.data < 0)
        self._clearance = None

    @property
    def clearance(self):
        """[m] from every cell's centre to the nearest blocked cell (computed on first use)."""
        if self._clearance is None:
            self._clearance = ndimage.distance_transform_edt(~self.blocked) * self.resolution
        return self._clearance

    def cells(self, xy):
        """(rows, cols, inside) of points [N, 2] in the map frame (rows and cols clipped to the grid)."""
        ox, oy, oyaw = self.origin
        pts = np.asarray(xy, dtype=float).reshape(-1, 2) - (ox, oy)
        c, s = math.cos(oyaw), math.sin(oyaw)
        with np.errstate(invalid="ignore"):
            u = np.floor((c * pts[:, 0] + s * pts[:, 1]) / self.resolution)
            v = np.floor((-s * pts[:, 0] + c * pts[:, 1]) / self.resolution)
        h, w = self.blocked.shape
        inside = np.isfinite(u) & np.isfinite(v) & (v >= 0) & (v < h) & (u >= 0) & (u < w)
        rows = np.clip(np.nan_to_num(v, nan=0.0), 0, h - 1).astype(int)
        cols = np.clip(np.nan_to_num(u, nan=0.0), 0, w - 1).astype(int)
        return rows, cols, inside

    def blocked_at(self, xy):
        """bool [N]: the points [N, 2] fall in a blocked cell or off the grid."""
        rows, cols, inside = self.cells(xy)
        return ~inside | self.blocked[rows, cols]

    def clearance_at(self, xy):
        """[m] at points [N, 2] (0 off the grid)."""
        rows, cols, inside = self.cells(xy)
        return np.where(inside, self.clearance[rows, cols], 0.0)

    def line_of_sight(self, starts, ends, step=None):
        """bool [N]: the straight segments from ``starts`` [N, 2] to ``ends`` ([N, 2], or one (x, y)
        for all) cross no blocked cell, sampled every ``step`` [m] (half a cell by default)."""
        starts = np.asarray(starts, dtype=float).reshape(-1, 2)
        ends = np.broadcast_to(np.asarray(ends, dtype=float), starts.shape)
        step = step or self.resolution / 2
        n = max(2, math.ceil(float(np.max(np.hypot(*(ends - starts).T), initial=0.0)) / step) + 1)
        t = np.linspace(0.0, 1.0, n)
        samples = starts[:, None, :] + t[None, :, None] * (ends - starts)[:, None, :]  # [N, n, 2]
        return ~self.blocked_at(samples.reshape(-1, 2)).reshape(len(starts), n).any(axis=1)

    def sight_matrix(self, starts, ends, skip_end=0.0, max_length=math.inf):
        """bool [N, M]: the segment from ``starts[i]`` to ``ends[j]`` ([N, 2], [M, 2] [m]) crosses no
        blocked cell (sampled as :meth:`line_of_sight`), its last ``skip_end`` [m] not looked at (the
        chair a person sits on); a pair longer than ``max_length`` [m] is False."""
        starts = np.ascontiguousarray(np.asarray(starts, dtype=float).reshape(-1, 2))
        ends = np.ascontiguousarray(np.asarray(ends, dtype=float).reshape(-1, 2))
        ox, oy, oyaw = self.origin
        return _SIGHT_MATRIX(self.blocked, ox, oy, math.cos(oyaw), math.sin(oyaw), self.resolution, starts, ends,
                             float(skip_end), float(max_length), self.resolution / 2)

    def with_obstacles(self, other):
        """A grid like this one (its class, cells and origin) whose cells are blocked too where
        ``other`` (a Grid of any size, resolution and origin) has a blocked cell at their centre;
        cells off ``other`` are as they were."""
        h, w = self.blocked.shape
        ox, oy, oyaw = self.origin
        cols, rows = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        c, s = math.cos(oyaw), math.sin(oyaw)
        x = ox + (c * cols - s * rows) * self.resolution
        y = oy + (s * cols + c * rows) * self.resolution
        r, q, inside = other.cells(np.column_stack([x.ravel(), y.ravel()]))
        extra = (inside & other.blocked[r, q]).reshape(h, w)
        data = np.where(extra, max(100, self.occupied), self.data)
        return type(self)(data, self.origin, self.resolution, self.occupied)
