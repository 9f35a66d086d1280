"""The map as amcl sees it and the laser models (likelihood field, beam), vectorised over particles.

Like ROS amcl, a cell is free if its value is 0, occupied if 100 and unknown otherwise;
the map's origin yaw is ignored (ROS amcl ignores it too).

Laser data for the models is in the *base* frame: ``laser_xy`` (2,) is the laser's origin
on the base and ``bearings`` [B] the beam directions in the base frame [rad], both
computed by the node from the real laser -> base transform (an upside-down laser just
gives reversed bearings). Beams at or beyond ``range_max`` are "no return".

Both models weigh a particle with ``p = 1 + sum_beams pz^3`` (ROS amcl's ad hoc cube that
keeps one scan from overwhelming the filter).
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from florence_common.pose import beams_in_plane, transform_matrix

LASER_MODELS = ("likelihood_field", "beam", "likelihood_field_prob")


@dataclass
class LaserParams:
    z_hit: float = 0.95
    z_short: float = 0.1
    z_max: float = 0.05
    z_rand: float = 0.05
    sigma_hit: float = 0.2  # [m]
    lambda_short: float = 0.1  # [1/m]
    likelihood_max_dist: float = 2.0  # [m]
    interpolate: bool = False  # likelihood field: sub-cell distance to the obstacle surface (False: ROS)


class OccupancyMap:
    """Grid with cell states and the likelihood field (distance to the nearest occupied cell)."""

    def __init__(self, data, resolution, origin_xy, max_occ_dist=2.0):
        data = np.asarray(data)
        if data.ndim != 2 or data.size == 0:
            raise ValueError(f"map data must be a non-empty 2-D array, got shape {data.shape}")
        if not resolution > 0:
            raise ValueError(f"map resolution must be > 0, got {resolution}")
        self.resolution = float(resolution)  # [m/cell]
        self.origin = np.array(origin_xy[:2], dtype=float)  # [m] lower left corner of cell (0, 0)
        self.height, self.width = data.shape
        self.free = data == 0
        self.occupied = data == 100
        self.max_occ_dist = float(max_occ_dist)  # [m]
        if self.occupied.any():
            dist = ndimage.distance_transform_edt(~self.occupied) * self.resolution
        else:
            dist = np.full(data.shape, np.inf)
        self.dist = np.minimum(dist, self.max_occ_dist).astype(np.float32)  # [m]
        # The field with a one-cell border at max_occ_dist, flattened: lookups clip instead of masking.
        self._dist_padded = np.pad(self.dist, 1, constant_values=self.max_occ_dist).ravel()
        # Signed distance field for sub-cell interpolation [m]: outside obstacles the distance to the nearest
        # occupied cell's centre (as ROS), inside an obstacle minus the depth below its outermost cells
        # (boundary cells 0, the next layer -res ...). An occupied cell's centre is where the surface lies on
        # average, for a map made by a laser (the endpoint falls anywhere in the cell) as for florence_sim's
        # generate_map (a cell is occupied when its centre is within half a cell of the obstacle); the
        # cells' edges would make obstacles half a cell thicker. The sign keeps an endpoint that overshoots
        # the surface from scoring like a hit: with an unsigned field every endpoint inside a thick wall is
        # at distance 0, so a pose too far towards a wall ahead is not penalised.
        if self.occupied.any() and not self.occupied.all():
            depth = ndimage.distance_transform_edt(self.occupied) * self.resolution - self.resolution
            signed = np.where(self.occupied, -depth, dist)
        else:
            signed = np.where(self.occupied, 0.0, dist)
        signed = np.clip(signed, -self.max_occ_dist, self.max_occ_dist)
        self._signed_padded = np.pad(signed, 2, constant_values=self.max_occ_dist).astype(np.float32).ravel()
        rows, cols = np.nonzero(self.free)
        self.free_cells = np.column_stack([cols, rows])  # (col, row) of every free cell

    @property
    def has_free_cells(self):
        return len(self.free_cells) > 0

    def world_to_cell(self, x, y):
        """(x, y) [m] arrays to integer (col, row) arrays (may be outside the map)."""
        col = np.floor((np.asarray(x) - self.origin[0]) / self.resolution).astype(np.int64)
        row = np.floor((np.asarray(y) - self.origin[1]) / self.resolution).astype(np.int64)
        return col, row

    def inside(self, col, row):
        return (col >= 0) & (col < self.width) & (row >= 0) & (row < self.height)

    def distance_at(self, x, y):
        """Distance to the nearest occupied cell [m], max_occ_dist outside the map."""
        col, row = self.world_to_cell(x, y)
        np.clip(col + 1, 0, self.width + 1, out=col)
        np.clip(row + 1, 0, self.height + 1, out=row)
        return self._dist_padded[row * (self.width + 2) + col]

    def distance_interpolated(self, x, y):
        """|signed distance| to the nearest obstacle surface [m], bilinear between cell centres, capped at
        max_occ_dist.

        The surface runs through the outermost occupied cells' centres; inside an obstacle the distance is the
        depth below it. Unlike ``distance_at`` (ROS: the cell's centre-to-centre distance, 0 anywhere inside an
        obstacle) it is not quantised to the cell grid and does not reward an endpoint behind the surface.
        """
        u = (np.asarray(x) - self.origin[0]) / self.resolution - 0.5 + 2.0  # +2: the padding
        v = (np.asarray(y) - self.origin[1]) / self.resolution - 0.5 + 2.0
        u = np.clip(u, 0.0, self.width + 2.999)
        v = np.clip(v, 0.0, self.height + 2.999)
        i, j = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
        fu, fv = u - i, v - j
        stride = self.width + 4
        base = j * stride + i
        f = self._signed_padded
        d = ((f[base] * (1 - fu) + f[base + 1] * fu) * (1 - fv)
             + (f[base + stride] * (1 - fu) + f[base + stride + 1] * fu) * fv)
        return np.minimum(np.abs(d), self.max_occ_dist)

    def is_free(self, x, y):
        col, row = self.world_to_cell(x, y)
        ok = self.inside(col, row)
        out = np.zeros(np.shape(col), dtype=bool)
        out[ok] = self.free[row[ok], col[ok]]
        return out

    def random_free_poses(self, n, rng):
        """n poses uniform over the free cells' centres, yaw uniform in [-pi, pi)."""
        if not self.has_free_cells:
            raise ValueError("the map has no free cells")
        idx = rng.integers(0, len(self.free_cells), n)
        cells = self.free_cells[idx]
        x = self.origin[0] + (cells[:, 0] + 0.5) * self.resolution
        y = self.origin[1] + (cells[:, 1] + 0.5) * self.resolution
        return np.column_stack([x, y, rng.uniform(-np.pi, np.pi, n)])

    def calc_range(self, x, y, angle, max_range):
        """Ray-cast from (x, y) along angle [rad] (arrays of one shape) to the first non-free cell.

        Returns the range [m], max_range where nothing is hit within it (like ROS map_calc_range,
        leaving the map counts as max_range).
        """
        x, y, angle = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, angle)))
        shape = x.shape
        x, y, angle = x.ravel(), y.ravel(), angle.ravel()
        ranges = np.full(x.shape, float(max_range))
        step = self.resolution * 0.5
        steps = np.arange(0.0, max_range + step, step)
        active = np.arange(x.size)
        cos, sin = np.cos(angle), np.sin(angle)
        chunk = 24  # steps per batch: stop early once every ray has hit something
        for start in range(0, len(steps), chunk):
            if active.size == 0:
                break
            s = steps[start:start + chunk]
            px = x[active, None] + cos[active, None] * s[None, :]
            py = y[active, None] + sin[active, None] * s[None, :]
            col, row = self.world_to_cell(px, py)
            inside = self.inside(col, row)
            blocked = np.zeros(px.shape, dtype=bool)
            blocked[inside] = ~self.free[row[inside], col[inside]]
            left = ~inside
            hit_any = blocked.any(axis=1)
            first_hit = np.where(hit_any, blocked.argmax(axis=1), len(s))
            first_left = np.where(left.any(axis=1), left.argmax(axis=1), len(s))
            hit = hit_any & (first_hit < first_left)
            ranges[active[hit]] = np.minimum(s[first_hit[hit]], max_range)
            done = hit | (first_left < len(s))
            active = active[~done]
        return ranges.reshape(shape)


def beam_endpoints(particles, laser_xy, bearings, ranges):
    """World (x, y) [N, B] of every beam's endpoint for every particle."""
    c, s = np.cos(particles[:, 2:3]), np.sin(particles[:, 2:3])
    lx = particles[:, 0:1] + c * laser_xy[0] - s * laser_xy[1]
    ly = particles[:, 1:2] + s * laser_xy[0] + c * laser_xy[1]
    heading = particles[:, 2:3] + bearings[None, :]
    return lx + ranges[None, :] * np.cos(heading), ly + ranges[None, :] * np.sin(heading)


def likelihood_field_weights(particles, omap, laser_xy, bearings, ranges, range_max, params):
    """ROS amcl's likelihood field model: p = 1 + sum over beams with a return of pz^3.

    pz = z_hit * exp(-d^2 / (2 sigma_hit^2)) + z_rand / range_max, d the distance from the
    beam's endpoint to the nearest obstacle (capped at likelihood_max_dist; outside the
    map: the cap). NaN beams and beams at or beyond range_max are left out.
    """
    pz = _likelihood_field_pz(particles, omap, laser_xy, bearings, ranges, range_max, params)
    return np.ones(len(particles)) if pz is None else 1.0 + np.sum(pz**3, axis=1)


def _likelihood_field_pz(particles, omap, laser_xy, bearings, ranges, range_max, params):
    """pz (particles x beams) of the likelihood field for the beams with a return, or None without any."""
    ranges = np.asarray(ranges, dtype=float)
    bearings = np.asarray(bearings, dtype=float)
    use = np.isfinite(ranges) & (ranges < range_max)
    ranges, bearings = ranges[use], bearings[use]
    if ranges.size == 0:
        return None
    ex, ey = beam_endpoints(particles, laser_xy, bearings, ranges)
    d = omap.distance_interpolated(ex, ey) if params.interpolate else omap.distance_at(ex, ey)
    return params.z_hit * np.exp(-(d * d) / (2.0 * params.sigma_hit**2)) + params.z_rand / range_max


def likelihood_field_prob_weights(particles, omap, laser_xy, bearings, ranges, range_max, params):
    """ROS amcl's ``likelihood_field_prob`` model (without beam skipping): the product of the beams' pz.

    pz as in :func:`likelihood_field_weights`; p = exp(sum ln pz) over the beams with a return, so
    unlike the summed cubes every beam multiplies in and a few centimetres of misfit on many beams count.
    """
    pz = _likelihood_field_pz(particles, omap, laser_xy, bearings, ranges, range_max, params)
    return np.ones(len(particles)) if pz is None else np.exp(np.sum(np.log(pz), axis=1))


def beam_weights(particles, omap, laser_xy, bearings, ranges, range_max, params):
    """ROS amcl's beam model: expected range by ray casting in the map, four-part mixture per beam."""
    ranges = np.asarray(ranges, dtype=float)
    bearings = np.asarray(bearings, dtype=float)
    use = ~np.isnan(ranges)
    ranges, bearings = np.minimum(ranges[use], range_max), bearings[use]
    if ranges.size == 0:
        return np.ones(len(particles))
    c, s = np.cos(particles[:, 2]), np.sin(particles[:, 2])
    lx = particles[:, 0] + c * laser_xy[0] - s * laser_xy[1]
    ly = particles[:, 1] + s * laser_xy[0] + c * laser_xy[1]
    heading = particles[:, 2:3] + bearings[None, :]
    expected = omap.calc_range(lx[:, None], ly[:, None], heading, range_max)
    z = ranges[None, :] - expected
    pz = params.z_hit * np.exp(-(z * z) / (2.0 * params.sigma_hit**2))
    short = params.z_short * params.lambda_short * np.exp(-params.lambda_short * ranges)
    pz = pz + np.where(z < 0, short[None, :], 0.0)
    pz = pz + np.where(ranges >= range_max, params.z_max, 0.0)[None, :]
    pz = pz + np.where(ranges < range_max, params.z_rand / range_max, 0.0)[None, :]
    return 1.0 + np.sum(pz**3, axis=1)


def sensor_weights(model, particles, omap, laser_xy, bearings, ranges, range_max, params):
    if model == "likelihood_field":
        return likelihood_field_weights(particles, omap, laser_xy, bearings, ranges, range_max, params)
    if model == "likelihood_field_prob":
        return likelihood_field_prob_weights(particles, omap, laser_xy, bearings, ranges, range_max, params)
    if model == "beam":
        return beam_weights(particles, omap, laser_xy, bearings, ranges, range_max, params)
    raise ValueError(f"laser_model_type must be one of {LASER_MODELS}, got {model!r}")


def subsample_beams(count, max_beams):
    """Indices of the beams used, as ROS amcl picks them: every step-th beam from the first,
    step = max(1, (count - 1) // (max_beams - 1)) (integer division, so up to a few more than
    max_beams beams can be used, like ROS). max_beams must be >= 2.
    """
    if max_beams < 2:
        raise ValueError(f"laser_max_beams must be >= 2, got {max_beams}")
    step = max(1, (count - 1) // (max_beams - 1))
    return np.arange(0, max(count, 0), step)


def beams_in_base(translation, quaternion, angles):
    """Laser origin (x, y) [m] and beam bearings [rad] in the base frame.

    translation (x, y, z) and quaternion (x, y, z, w): the laser frame's pose in the base
    frame; angles [B]: beam angles in the laser frame. Each beam's direction is rotated
    through the full 3-D rotation and projected onto the base's x/y plane, so a laser
    mounted upside down (roll pi) simply gets mirrored bearings
    (:func:`florence_common.pose.beams_in_plane`).
    """
    xy, bearings, _ = beams_in_plane(transform_matrix(translation, quaternion), angles)
    return xy, bearings
