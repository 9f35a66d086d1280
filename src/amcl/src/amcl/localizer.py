"""amcl's update cycle without ROS: when to move, weigh and resample the particles.

The node hands every scan to :meth:`Localizer.process_scan` with the odometry pose of
the base at the scan's time and the beams already in the base frame. The rules are ROS
amcl's (laserReceived):

- the first scan after (re)initialisation only records the odometry pose and forces a
  sensor update;
- later scans update the filter only once the odometry moved more than update_min_d in x
  *or* in y, or more than update_min_a in yaw, since the last update (per axis, like ROS),
  or when a no-motion update was requested; the motion model then moves the particles by
  the whole odometry step since that update;
- after every sensor update the resample counter counts up and the set is resampled
  every resample_interval-th time (with selective_resampling only if N_eff < N/2; the estimate
  is published every resample_interval-th update either way, like ROS);
- the laser's range_max is min(scan range_max, laser_max_range if > 0), its range_min
  max(scan range_min, laser_min_range); readings at or below range_min count as
  range_max (ROS amcl has no min-range concept); NaN readings are left out.
"""

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from amcl.motion import MODELS, sample_motion
from amcl.params import FILTER
from amcl.particle_filter import FilterParams, ParticleFilter
from amcl.sensor import LASER_MODELS, LaserParams, OccupancyMap, sensor_weights, subsample_beams
from florence_common import angles

log = logging.getLogger(__name__)


@dataclass
class AmclConfig:
    """The ROS amcl parameters the filter itself uses (ROS names and defaults)."""

    filter: FilterParams = field(default_factory=FilterParams)
    laser: LaserParams = field(default_factory=LaserParams)
    laser_model_type: str = "likelihood_field"
    laser_max_beams: int = 30
    laser_min_range: float = -1.0  # [m], <= 0: the scan's own
    laser_max_range: float = -1.0  # [m], <= 0: the scan's own
    odom_model_type: str = "diff"
    odom_alphas: tuple = (0.2, 0.2, 0.2, 0.2, 0.2)
    update_min_d: float = 0.2  # [m]
    update_min_a: float = math.pi / 6.0  # [rad]
    off_free_weight: float = 1.0  # factor on p of particles not on a free cell (1: ROS behaviour)

    def validate(self):
        """Raise ValueError naming the parameter that is out of range."""
        self.filter.validate()
        if self.laser_model_type not in LASER_MODELS:
            raise ValueError(f"laser_model_type must be one of {LASER_MODELS}, got {self.laser_model_type!r}")
        if self.odom_model_type not in MODELS:
            raise ValueError(f"odom_model_type must be one of {MODELS}, got {self.odom_model_type!r}")
        if self.laser_max_beams < 2:
            raise ValueError(f"laser_max_beams must be >= 2, got {self.laser_max_beams}")
        for i, a in enumerate(self.odom_alphas, start=1):
            if not (math.isfinite(a) and a >= 0.0):
                raise ValueError(f"odom_alpha{i} must be >= 0, got {a}")
        for name in ("z_hit", "z_short", "z_max", "z_rand"):
            if not getattr(self.laser, name) >= 0.0:
                raise ValueError(f"laser_{name} must be >= 0, got {getattr(self.laser, name)}")
        for name in ("sigma_hit", "lambda_short", "likelihood_max_dist"):
            if not getattr(self.laser, name) > 0.0:
                raise ValueError(f"laser_{name} must be > 0, got {getattr(self.laser, name)}")
        if not 0.0 <= self.off_free_weight <= 1.0:
            raise ValueError(f"off_free_weight must be in [0, 1], got {self.off_free_weight}")
        if not (self.update_min_d >= 0.0 and self.update_min_a >= 0.0):
            raise ValueError("update_min_d and update_min_a must be >= 0")


def config_from_params(get):
    """AmclConfig from ROS amcl parameters: ``get(name, default)`` returns ``~name`` (ROS names and defaults,
    amcl.params.FILTER).

    The node passes ``rospy.get_param``; the offline evaluation passes a launch file's ``<param>`` values.
    Raises ValueError naming a parameter that is out of range.
    """
    p = FILTER.read(get)
    filt = FilterParams(
        min_particles=p.min_particles, max_particles=p.max_particles, kld_err=p.kld_err, kld_z=p.kld_z,
        recovery_alpha_slow=p.recovery_alpha_slow, recovery_alpha_fast=p.recovery_alpha_fast,
        resample_interval=p.resample_interval, selective_resampling=p.selective_resampling,
        recovery_mean_likelihood=p.recovery_mean_likelihood, recovery_wait_converged=p.recovery_wait_converged)
    laser = LaserParams(
        z_hit=p.laser_z_hit, z_short=p.laser_z_short, z_max=p.laser_z_max, z_rand=p.laser_z_rand,
        sigma_hit=p.laser_sigma_hit, lambda_short=p.laser_lambda_short,
        likelihood_max_dist=p.laser_likelihood_max_dist, interpolate=p.laser_likelihood_interpolate)
    config = AmclConfig(
        filter=filt, laser=laser, laser_model_type=p.laser_model_type, laser_max_beams=p.laser_max_beams,
        laser_min_range=p.laser_min_range, laser_max_range=p.laser_max_range, odom_model_type=p.odom_model_type,
        odom_alphas=tuple(p[f"odom_alpha{i}"] for i in range(1, 6)), update_min_d=p.update_min_d,
        update_min_a=p.update_min_a, off_free_weight=p.off_free_weight)
    config.validate()
    return config


@dataclass
class UpdateResult:
    """What one scan did. pose: (x, y, yaw) in the map frame; cov: 3x3; particles [N, 3]."""

    updated: bool
    resampled: bool
    pose: np.ndarray | None = None
    cov: np.ndarray | None = None
    clusters: int = 0
    reason: str = ""


class Localizer:
    """The filter plus the update bookkeeping of ROS amcl."""

    def __init__(self, config=None, rng=None):
        self.config = config or AmclConfig()
        self.config.validate()
        self.rng = np.random.default_rng() if rng is None else rng
        self.pf = ParticleFilter(self.config.filter, self.rng)
        self.map = None
        self.odom_pose = None  # odometry pose at the last filter update (None: not yet initialised)
        self.force_update = False
        self.resample_count = 0
        self.last_estimate = None  # (pose, cov)

    def set_map(self, data, resolution, origin_xy):
        """A new map (data [H, W] int8 values, row 0 at origin_xy); the filter is re-initialised by the caller."""
        self.map = OccupancyMap(data, resolution, origin_xy, self.config.laser.likelihood_max_dist)
        if not self.map.has_free_cells:
            log.warning("the map has no free cells: localization cannot run on it")

    def set_pose(self, mean, cov):
        """(Re)initialise the particles around mean (x, y, yaw) with covariance cov (3x3)."""
        self.pf.init_gaussian(mean, cov)
        self._reinitialised()

    def global_localization(self):
        """Spread the particles over the map's free space. Raises ValueError without a usable map."""
        if self.map is None or not self.map.has_free_cells:
            raise ValueError("no map with free cells to spread the particles over")
        self.pf.init_uniform(self.map)
        self._reinitialised()

    def request_nomotion_update(self):
        self.force_update = True

    def _reinitialised(self):
        self.odom_pose = None
        self.last_estimate = None

    def laser_ranges(self, ranges, scan_range_min, scan_range_max):
        """(ranges with short readings at range_max, range_max) per the rules in the module doc."""
        c = self.config
        range_max = min(scan_range_max, c.laser_max_range) if c.laser_max_range > 0 else scan_range_max
        range_min = max(scan_range_min, c.laser_min_range)
        ranges = np.asarray(ranges, dtype=float).copy()
        ranges[ranges <= range_min] = range_max
        return ranges, float(range_max)

    def moved_enough(self, odom_pose):
        d = np.asarray(odom_pose, dtype=float) - self.odom_pose
        return (abs(d[0]) > self.config.update_min_d or abs(d[1]) > self.config.update_min_d
                or abs(angles.diff(odom_pose[2], self.odom_pose[2])) > self.config.update_min_a)

    def unusable(self, odom_pose, bearings, ranges):
        """Why a scan cannot be used ("" if it can)."""
        if self.map is None:
            return "no map yet"
        if not self.map.has_free_cells:
            return "the map has no free cells"
        if ranges.size == 0 or ranges.shape != bearings.shape:
            return f"scan with {ranges.size} ranges for {bearings.size} beams"
        if np.isnan(ranges).all():
            return "scan has only NaN ranges"
        if not np.isfinite(odom_pose).all():
            return "odometry pose is not finite"
        return ""

    def process_scan(self, odom_pose, laser_xy, bearings, ranges, scan_range_min, scan_range_max):
        """One scan: odom_pose (x, y, yaw) of the base in the odom frame at the scan's time;
        laser_xy (2,) and bearings [B] in the base frame (every beam of the scan); ranges [B] [m].
        """
        ranges = np.asarray(ranges, dtype=float)
        bearings = np.asarray(bearings, dtype=float)
        odom_pose = np.asarray(odom_pose, dtype=float)
        problem = self.unusable(odom_pose, bearings, ranges)
        if problem:
            return UpdateResult(False, False, reason=problem)
        c = self.config
        if self.odom_pose is None:
            self.odom_pose = odom_pose
            self.force_update = True
            self.resample_count = 0
        elif self.moved_enough(odom_pose) or self.force_update:
            old = self.odom_pose
            self.pf.predict(lambda p: sample_motion(p, old, odom_pose, c.odom_alphas, c.odom_model_type, self.rng))
            self.odom_pose = odom_pose
            self.force_update = True
        if not self.force_update:
            return UpdateResult(False, False, reason="not moved enough")
        self.force_update = False
        use = subsample_beams(len(ranges), c.laser_max_beams)
        ranges, range_max = self.laser_ranges(ranges[use], scan_range_min, scan_range_max)
        weights = sensor_weights(c.laser_model_type, self.pf.particles, self.map, np.asarray(laser_xy, dtype=float),
                                 bearings[use], ranges, range_max, c.laser)
        if c.off_free_weight < 1.0:
            weights = np.where(self.map.is_free(self.pf.particles[:, 0], self.pf.particles[:, 1]), weights,
                               weights * c.off_free_weight)
        self.pf.update_sensor(weights)
        self.resample_count += 1
        # "resampled" is ROS's flag: the resample step ran (the node publishes amcl_pose then), also when
        # selective_resampling kept the set.
        resampled = self.resample_count % c.filter.resample_interval == 0
        if resampled:
            self.pf.resample(self.map)
        pose, cov, clusters = self.pf.estimate()
        self.last_estimate = (pose, cov)
        return UpdateResult(True, resampled, pose, cov, clusters)


def map_to_odom(map_pose, odom_pose):
    """The map -> odom transform (x, y, yaw) from the base's pose in map and in odom."""
    mx, my, ma = map_pose
    ox, oy, oa = odom_pose
    yaw = float(angles.diff(ma, oa))
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([mx - (c * ox - s * oy), my - (s * ox + c * oy), yaw])
