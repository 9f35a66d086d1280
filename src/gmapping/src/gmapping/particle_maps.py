"""Every particle's own map, in one pool of copy-on-write patches (no ROS).

GMapping's particles each match scans against their own map. That map stores, per cell, how many
beams ended in it and the mean of those end points; nothing else (openslam_gmapping's particles
register scans with ``generateMap`` off: hits only). A cell is "full" once a beam ended in it and
"free" as long as none did.

Here the maps live in one pool of square patches of PATCH x PATCH cells. Each particle has a grid of
patch ids (``index``, -1 where it has no patch yet); after resampling, copies of a particle share
all its patches, and a patch is copied only when a particle writes into one it shares (reference
counts). Every particle therefore sees exactly its own map, as if each had a private copy, while
memory grows with what the particles do not have in common (GMapping itself shares patches the same
way, through its HierarchicalArray2D and autoptr).

Cells: cell (cx, cy) covers [cx delta, (cx + 1) delta) x [cy delta, (cy + 1) delta) in the map
frame. A cell keeps its hit count and the sums of its hits' offsets from the cell's centre (float32
offsets stay exact where sums of map coordinates would not).
"""

import math

import numba
import numpy as np

PATCH_BITS = 4
PATCH = 1 << PATCH_BITS  # cells along a patch's side
PATCH_MASK = PATCH - 1
# the pool's fields, per cell: hits; sums of the hits' offsets from the cell's centre [m], of their squares and
# product [m^2]; sums of the unit directions of the beams that ended there (which way the surface faces)
HITS, SUM_X, SUM_Y, SUM_XX, SUM_XY, SUM_YY, SUM_UX, SUM_UY = range(8)
FIELDS = 8


class ParticleMaps:
    """The hit maps of ``count`` particles at ``delta`` [m/cell]."""

    def __init__(self, count, delta, capacity=256):
        self.delta = float(delta)
        self.pool = np.zeros((capacity, FIELDS, PATCH, PATCH), np.float32)
        self.refs = np.zeros(capacity, np.int32)  # how many particles use each patch
        self.free = np.arange(capacity - 1, -1, -1, dtype=np.int32)  # unused patch ids, a stack
        self.n_free = np.array([capacity], np.int64)  # its height (an array: the kernels change it)
        self.index = np.full((int(count), 0, 0), -1, np.int32)  # [particle, patch row, patch column]
        self.origin = np.zeros(2, np.int64)  # (patch column, patch row) of index[:, 0, 0]

    @property
    def count(self):
        return self.index.shape[0]

    @property
    def capacity(self):
        return self.pool.shape[0]

    def patches_in_use(self):
        return int(self.capacity - self.n_free[0])

    def nbytes(self):
        return self.pool.nbytes + self.refs.nbytes + self.free.nbytes + self.index.nbytes

    # ---- extent ----------------------------------------------------------------------------------
    def cover(self, xmin, ymin, xmax, ymax):
        """Grow every particle's patch grid to cover the box [m] (never shrinks)."""
        lo = np.array([math.floor(xmin / self.delta), math.floor(ymin / self.delta)], np.int64) >> PATCH_BITS
        hi = np.array([math.floor(xmax / self.delta), math.floor(ymax / self.delta)], np.int64) >> PATCH_BITS
        rows, cols = self.index.shape[1:]
        if rows == 0:
            self.origin = lo
            self.index = np.full((self.count, hi[1] - lo[1] + 1, hi[0] - lo[0] + 1), -1, np.int32)
            return
        new_lo = np.minimum(lo, self.origin)
        new_hi = np.maximum(hi, self.origin + np.array([cols - 1, rows - 1]))
        if (new_lo == self.origin).all() and (new_hi == self.origin + np.array([cols - 1, rows - 1])).all():
            return
        before = self.origin - new_lo
        after = new_hi - (self.origin + np.array([cols - 1, rows - 1]))
        self.index = np.pad(self.index, ((0, 0), (before[1], after[1]), (before[0], after[0])), constant_values=-1)
        self.origin = new_lo

    def _grow_pool(self, needed):
        old = self.capacity
        new = max(2 * old, old + int(needed))
        self.pool = np.concatenate([self.pool, np.zeros((new - old, FIELDS, PATCH, PATCH), np.float32)])
        self.refs = np.concatenate([self.refs, np.zeros(new - old, np.int32)])
        top = int(self.n_free[0])
        free = np.empty(new, np.int32)
        free[: new - old] = np.arange(new - 1, old - 1, -1, dtype=np.int32)
        free[new - old: new - old + top] = self.free[:top]
        self.free, self.n_free = free, np.array([top + new - old], np.int64)

    # ---- writing ---------------------------------------------------------------------------------
    def register(self, poses, laser, ranges, usable, particles=None):
        """Add the end points of one scan to each particle's map (GMapping's registerScan without
        generateMap): every reading up to ``usable`` [m] counts a hit in the cell it ends in.

        poses [N, 3] (x, y, yaw of the base in the map); ``laser`` a LaserGeometry; ranges [B] [m] (inf: no
        reading); ``particles``: which rows of the maps the poses belong to (default: 0..N-1). The caller
        has covered the scan's extent (:meth:`cover`)."""
        poses = np.ascontiguousarray(poses, dtype=np.float64).reshape(-1, 3)
        rows = np.arange(len(poses)) if particles is None else np.asarray(particles, np.int64)
        ranges = np.asarray(ranges, np.float64)
        worst = int(np.count_nonzero(ranges <= usable))  # new patches one particle may need at most
        start = 0
        while start < len(poses):
            if self.n_free[0] < worst:
                self._grow_pool(worst)
            start = _register(self.pool, self.refs, self.free, self.n_free, self.index, self.origin[0],
                              self.origin[1], poses, rows, laser.x, laser.y, laser.cos, laser.sin, ranges,
                              float(usable), self.delta, start, worst)

    def share(self, source=0):
        """Every particle takes particle ``source``'s map (all start from the first scan alike)."""
        self.resample(np.full(self.count, source))

    def resample(self, parents):
        """Particle i takes particle parents[i]'s map (shared until either writes)."""
        self.index = self.index[np.asarray(parents, np.int64)]
        used = self.index[self.index >= 0]
        self.refs = np.bincount(used, minlength=self.capacity).astype(np.int32)
        unused = np.flatnonzero(self.refs == 0).astype(np.int32)
        self.free[: len(unused)] = unused[::-1]
        self.n_free[0] = len(unused)

    # ---- reading (tests, pictures) ----------------------------------------------------------------
    def dense(self, particle):
        """(hits [H, W], mean x [H, W], mean y [H, W] (NaN where no hit), origin (x, y) [m] of cell (0, 0)) of
        one particle's map: rows are y, columns x."""
        rows, cols = self.index.shape[1:]
        hits = np.zeros((rows * PATCH, cols * PATCH), np.float32)
        sums = np.zeros((2, rows * PATCH, cols * PATCH), np.float32)
        for r in range(rows):
            for c in range(cols):
                pid = self.index[particle, r, c]
                if pid >= 0:
                    block = np.s_[r * PATCH:(r + 1) * PATCH, c * PATCH:(c + 1) * PATCH]
                    hits[block] = self.pool[pid, HITS]
                    sums[0][block] = self.pool[pid, SUM_X]
                    sums[1][block] = self.pool[pid, SUM_Y]
        origin = (self.origin * PATCH).astype(float) * self.delta
        centre_x = origin[0] + (np.arange(cols * PATCH) + 0.5) * self.delta
        centre_y = origin[1] + (np.arange(rows * PATCH) + 0.5) * self.delta
        with np.errstate(invalid="ignore", divide="ignore"):
            mean_x = np.where(hits > 0, centre_x[None, :] + sums[0] / hits, np.nan)
            mean_y = np.where(hits > 0, centre_y[:, None] + sums[1] / hits, np.nan)
        return hits, mean_x, mean_y, (float(origin[0]), float(origin[1]))


@numba.njit(cache=True, nogil=True)
def _take_patch(pool, free, n_free):
    n_free[0] -= 1
    return free[n_free[0]]


@numba.njit(cache=True, nogil=True)
def _register(pool, refs, free, n_free, index, ox, oy, poses, rows, lx, ly, bcos, bsin, ranges, usable, delta,
              start, worst):
    """Register the scan into the maps of particles start.. ; returns the first particle not done (the pool
    ran short of ``worst`` free patches before it) or len(poses)."""
    n_rows, n_cols = index.shape[1], index.shape[2]
    for k in range(start, poses.shape[0]):
        if n_free[0] < worst:
            return k
        p = rows[k]
        c, s = math.cos(poses[k, 2]), math.sin(poses[k, 2])
        ox_l = poses[k, 0] + c * lx - s * ly
        oy_l = poses[k, 1] + s * lx + c * ly
        for b in range(ranges.shape[0]):
            r = ranges[b]
            if not r <= usable:
                continue
            ux = c * bcos[b] - s * bsin[b]
            uy = s * bcos[b] + c * bsin[b]
            hx = ox_l + r * ux
            hy = oy_l + r * uy
            cx = math.floor(hx / delta)
            cy = math.floor(hy / delta)
            qx = (cx >> PATCH_BITS) - ox
            qy = (cy >> PATCH_BITS) - oy
            if qx < 0 or qy < 0 or qx >= n_cols or qy >= n_rows:
                continue
            pid = index[p, qy, qx]
            if pid < 0:
                pid = _take_patch(pool, free, n_free)
                pool[pid] = 0.0
                refs[pid] = 1
                index[p, qy, qx] = pid
            elif refs[pid] > 1:  # shared: this particle gets its own copy before writing
                new = _take_patch(pool, free, n_free)
                pool[new] = pool[pid]
                refs[pid] -= 1
                refs[new] = 1
                index[p, qy, qx] = new
                pid = new
            i = cy & PATCH_MASK
            j = cx & PATCH_MASK
            ex = hx - (cx + 0.5) * delta
            ey = hy - (cy + 0.5) * delta
            pool[pid, HITS, i, j] += 1.0
            pool[pid, SUM_X, i, j] += ex
            pool[pid, SUM_Y, i, j] += ey
            pool[pid, SUM_XX, i, j] += ex * ex
            pool[pid, SUM_XY, i, j] += ex * ey
            pool[pid, SUM_YY, i, j] += ey * ey
            pool[pid, SUM_UX, i, j] += ux
            pool[pid, SUM_UY, i, j] += uy
    return poses.shape[0]
