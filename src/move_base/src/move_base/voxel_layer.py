"""costmap_2d's VoxelLayer in numpy and numba (ROS-free): obstacles in 3-D, so that what one
sensor sees at one height is not cleared by another sensor's ray at another height.

Each cell of the 2-D grid holds a column of ``z_voxels`` voxels of ``z_resolution`` [m] from
``origin_z`` [m] up, stored as the bits of a ``uint32`` (bit k: the voxel from origin_z + k *
z_resolution), as ROS's voxel_grid does. On each update:

1. Clearing: every ray of a clearing observation, from the sensor's origin to each of its points
   (all of them, whatever their height: a floor point seen free clears the air on the way) and
   along each ray that saw nothing (a LaserScan reading at or beyond range_max) for
   raytrace_range, clears the voxels it passes through (not the one its point lies in), cut at
   raytrace_range (in the plane) and to the grid (x, y and the column's height).
2. Marking: the points of a marking observation between min_obstacle_height and
   max_obstacle_height and nearer than obstacle_range (3-D) to the sensor set their voxel.
3. A cell whose column holds more than ``mark_threshold`` voxels is LETHAL_OBSTACLE, any other
   FREE_SPACE (unknown voxels are not tracked: the seed's costmaps have
   track_unknown_space false, where ROS's unknown_threshold never applies either).

So a table top 0.71 m up that the Kinect saw stays in the column when the robot comes so close
that the Kinect (blind within about 0.5 m) no longer sees it, and the Hokuyo's beam under the
table, 0.17 m up, clears only its own voxels. ROS differs in one point: its ObservationBuffer
drops points outside the height limits for clearing too, so a Kinect's floor points clear
nothing (ros-planning/navigation #662, #942); here they clear the air above the floor.

Ray tracing is one numba kernel over all rays (3-D Bresenham: one voxel per step along the
dominant axis, in cell units, z in z_resolution cells). Rays ending in the same voxel trace the
same cells (to within the sub-voxel start of the same origin) and are traced once.
"""

import logging
import math

import numba
import numpy as np

from move_base.costmap_2d import FREE_SPACE, LETHAL_OBSTACLE, Costmap2D
from move_base.layers import ObstacleLayer, _window

log = logging.getLogger(__name__)

MAX_Z_VOXELS = 32  # bits of a column


def popcount32(bits):
    """Number of set bits of each uint32 in ``bits`` (array)."""
    b = np.asarray(bits, dtype=np.uint32)
    b = b - ((b >> 1) & np.uint32(0x55555555))
    b = (b & np.uint32(0x33333333)) + ((b >> 2) & np.uint32(0x33333333))
    b = (b + (b >> 4)) & np.uint32(0x0F0F0F0F)
    return ((b * np.uint32(0x01010101)) & np.uint32(0xFFFFFFFF)) >> 24


@numba.njit(cache=True)
def _trace(bits, visited, z_voxels, start, ends, include_end):  # pragma: no cover - compiled
    """Clear the voxels on the rays from ``start`` (3,) to each of ``ends`` (N, 3), both in voxel
    units (x, y in cells, z in z cells: voxel (i, j, k) spans [i, i + 1) x [j, j + 1) x [k, k +
    1)), one voxel per step along the ray's dominant axis, the end voxel only where
    ``include_end[n]``. Each ray is first cut to the grid (x, y on it, 0 <= z < z_voxels); a cut
    ray clears its new end voxel too. Rays ending in a voxel an earlier ray of this call ended in
    are skipped (they cross the same voxels but for sub-voxel differences): ``visited`` (size_y,
    size_x, z_voxels) bool, all False on entry and on return."""
    size_y, size_x = bits.shape
    sx, sy, sz = start[0], start[1], start[2]
    lim = (size_x - 1e-6, size_y - 1e-6, z_voxels - 1e-6)
    n_seen = 0
    seen = np.empty(ends.shape[0], np.int64)
    for r in range(ends.shape[0]):
        d = (ends[r, 0] - sx, ends[r, 1] - sy, ends[r, 2] - sz)
        o = (sx, sy, sz)
        t_end = 1.0
        for a in range(3):  # cut to the box [0, lim)
            if d[a] > 0.0 and o[a] + d[a] > lim[a]:
                t_end = min(t_end, (lim[a] - o[a]) / d[a])
            elif d[a] < 0.0 and o[a] + d[a] < 0.0:
                t_end = min(t_end, -o[a] / d[a])
        if t_end <= 0.0:
            continue
        inc = include_end[r] or t_end < 1.0
        dx, dy, dz = d[0] * t_end, d[1] * t_end, d[2] * t_end
        ex = math.floor(sx + dx)
        ey = math.floor(sy + dy)
        ez = math.floor(sz + dz)
        if ex < 0 or ey < 0 or ez < 0 or ex >= size_x or ey >= size_y or ez >= z_voxels:
            continue
        if visited[ey, ex, ez]:
            continue
        visited[ey, ex, ez] = True
        seen[n_seen] = (ey * size_x + ex) * z_voxels + ez
        n_seen += 1
        steps = math.ceil(max(abs(dx), abs(dy), abs(dz)))
        for k in range(steps + 1):
            t = k / steps if steps > 0 else 1.0
            ix = math.floor(sx + dx * t)
            iy = math.floor(sy + dy * t)
            iz = math.floor(sz + dz * t)
            at_end = ix == ex and iy == ey and iz == ez
            if at_end and not inc:
                break
            if 0 <= ix < size_x and 0 <= iy < size_y and 0 <= iz < z_voxels:
                bits[iy, ix] &= ~np.uint32(1 << iz)
            if at_end:
                break
    flat = visited.reshape(-1)
    for i in range(n_seen):
        flat[seen[i]] = False


@numba.njit(cache=True)
def _mark(bits, z_voxels, points):  # pragma: no cover - compiled
    """Set the voxel of every point (N, 3) in voxel units that lies on the grid (a point below
    z 0 sets the lowest voxel, as ROS's)."""
    size_y, size_x = bits.shape
    for i in range(points.shape[0]):
        ix = math.floor(points[i, 0])
        iy = math.floor(points[i, 1])
        iz = max(math.floor(points[i, 2]), 0)
        if 0 <= ix < size_x and 0 <= iy < size_y and iz < z_voxels:
            bits[iy, ix] |= np.uint32(1 << iz)


class VoxelLayer(ObstacleLayer):
    """Obstacles in voxel columns (costmap_2d VoxelLayer, ``map_type: voxel``).

    Args as :class:`~move_base.layers.ObstacleLayer`, plus origin_z [m] (bottom of the columns),
    z_resolution [m] (voxel height), z_voxels (voxels per column, 1..32) and mark_threshold
    (marked voxels a column may hold and still be free; ROS's default 0: any marks it).
    """

    def __init__(self, sources=(), track_unknown_space=False, now=0.0, origin_z=0.0, z_resolution=0.2, z_voxels=10,
                 mark_threshold=0):
        super().__init__(sources, track_unknown_space, now)
        if not 1 <= int(z_voxels) <= MAX_Z_VOXELS:
            raise ValueError(f"z_voxels must be 1..{MAX_Z_VOXELS}, got {z_voxels}")
        if not z_resolution > 0.0:
            raise ValueError(f"z_resolution must be > 0, got {z_resolution}")
        self.origin_z = float(origin_z)
        self.z_resolution = float(z_resolution)
        self.z_voxels = int(z_voxels)
        self.mark_threshold = int(mark_threshold)
        self.bits = None  # uint32 (size_y, size_x): one column of voxels per cell
        self._visited = None  # bool (size_y, size_x, z_voxels): scratch of the ray tracing

    @property
    def top_z(self):
        """Height [m] of the top of the columns."""
        return self.origin_z + self.z_voxels * self.z_resolution

    def match_size(self, master):
        super().match_size(master)
        self.bits = np.zeros(self.grid.costs.shape, dtype=np.uint32)

    def update_origin(self, origin_x, origin_y):
        g = self.grid
        cell_ox = int((origin_x - g.origin_x) / g.resolution)
        cell_oy = int((origin_y - g.origin_y) / g.resolution)
        if cell_ox or cell_oy:
            shifted = Costmap2D(g.size_x, g.size_y, g.resolution, g.origin_x, g.origin_y)
            shifted.costs = self.bits  # the same shift as the costs (Costmap2D.update_origin), on the columns
            shifted.default_value = 0
            shifted.update_origin(origin_x, origin_y)
            self.bits = shifted.costs
        g.update_origin(origin_x, origin_y)

    def reset(self, now=None):
        super().reset(now)
        if self.bits is not None:
            self.bits[...] = 0

    def clear_cells(self, mx, my):
        """Empty the columns of cells (mx, my) (index arrays): under the robot's footprint."""
        super().clear_cells(mx, my)
        self.bits[my, mx] = 0

    def clear_outside(self, x, y, size):
        keep = super().clear_outside(x, y, size)
        if keep is not None:
            self.bits[~keep] = 0
        return keep

    def clear_unknown_around(self, x, y, size):
        super().clear_unknown_around(x, y, size)  # columns keep their marks: unknown is not tracked

    def band(self, z_band):
        """Cells with a marked voxel overlapping the heights ``z_band`` = (low, high) [m]."""
        lo = max(0, math.floor((z_band[0] - self.origin_z) / self.z_resolution))
        hi = min(self.z_voxels - 1, math.floor((z_band[1] - self.origin_z) / self.z_resolution))
        if hi < lo:
            return np.zeros(self.bits.shape, dtype=bool)
        mask = np.uint32(((1 << (hi + 1)) - 1) & ~((1 << lo) - 1))
        return (self.bits & mask) != 0

    def voxel_centres(self):
        """(N, 3) centres [m] of the marked voxels, in the grid's frame (for a picture in rviz)."""
        g = self.grid
        if g is None or self.bits is None:
            return np.zeros((0, 3))
        my, mx = np.nonzero(self.bits)
        col = self.bits[my, mx]
        k = np.arange(self.z_voxels, dtype=np.uint32)
        on = ((col[:, None] >> k[None, :]) & np.uint32(1)).astype(bool)
        rows, levels = np.nonzero(on)
        wx, wy = g.map_to_world(mx[rows], my[rows])
        wz = self.origin_z + (levels + 0.5) * self.z_resolution
        return np.column_stack([np.atleast_1d(wx), np.atleast_1d(wy), wz])

    # --- the update ------------------------------------------------------------------------------
    def update(self, clear_discs=None):
        if self.grid is None:
            return
        for b in self.buffers.values():
            b.purge()
        for b in self.buffers.values():
            if b.source.clearing:
                for obs in b.observations:
                    self._clear(b.source, obs)
        self.clear_discs(clear_discs)
        for b in self.buffers.values():
            if b.source.marking:
                for obs in b.observations:
                    self._mark_voxels(b.source, obs)
        marked = popcount32(self.bits) > self.mark_threshold
        self.grid.costs[...] = np.where(marked, LETHAL_OBSTACLE, FREE_SPACE).astype(np.uint8)

    def _to_voxels(self, points):
        """Points (N, 3) [m] in voxel units (contiguous float64)."""
        g = self.grid
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        scale = np.array([g.resolution, g.resolution, self.z_resolution])  # divided, as Costmap2D.world_to_map
        return np.ascontiguousarray((p - np.array([g.origin_x, g.origin_y, self.origin_z])) / scale)

    def _clear(self, src, obs):
        g = self.grid
        origin = np.asarray(obs.origin, dtype=float)
        if g.world_to_map(origin[0], origin[1]) is None:
            log.warning("the origin of sensor %s at (%.2f, %.2f) is off the costmap: it cannot clear", src.name,
                        origin[0], origin[1])
            return
        rr = src.raytrace_range
        # real returns (every height), cut at raytrace_range in the plane: the end voxel is cleared
        # only when cut; rays that saw nothing: raytrace_range long, end voxel cleared
        points = obs.points if obs.clear_points is None else obs.clear_points
        d = np.asarray(points, dtype=float).reshape(-1, 3) - origin
        length = np.hypot(d[:, 0], d[:, 1])
        cut = length > rr
        d[cut] *= (rr / length[cut])[:, None]
        f = np.asarray(obs.free_ends, dtype=float).reshape(-1, 3) - origin
        flen = np.hypot(f[:, 0], f[:, 1])
        f = f[flen > 0] * (rr / flen[flen > 0])[:, None]
        if len(d) + len(f) == 0:
            return
        ends = self._to_voxels(origin + np.concatenate([d, f]))
        include = np.concatenate([cut, np.ones(len(f), dtype=bool)])
        if self._visited is None or self._visited.shape[:2] != self.bits.shape:
            self._visited = np.zeros((*self.bits.shape, self.z_voxels), dtype=np.bool_)
        _trace(self.bits, self._visited, self.z_voxels, self._to_voxels(origin[None, :])[0], ends, include)

    def _mark_voxels(self, src, obs):
        p = np.asarray(obs.points, dtype=float).reshape(-1, 3)  # already within the height limits
        if len(p) == 0:
            return
        near = np.sum((p - obs.origin) ** 2, axis=1) < src.obstacle_range * src.obstacle_range
        _mark(self.bits, self.z_voxels, self._to_voxels(p[near]))


def voxel_window(layer, x, y, size):
    """The columns of ``layer`` in the square of side ``size`` [m] round (x, y) [m] (tests)."""
    return layer.bits[_window(layer.grid, x, y, size)]
