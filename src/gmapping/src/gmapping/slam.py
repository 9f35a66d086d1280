"""GMapping without ROS: a Rao-Blackwellized particle filter that builds a grid map from laser scans
and odometry (openslam_gmapping's GridSlamProcessor, as slam_gmapping drives it).

Each particle is a trajectory of robot poses with its own map. For every scan the node hands over the
odometry pose of the base at the scan's time, the laser's geometry (from tf) and the readings:

1. every particle moves by the odometry step, with GMapping's motion noise (:mod:`gmapping.motion`);
2. the scan is *processed* only when the robot has travelled linearUpdate or turned angularUpdate since
   the last processed one (or temporalUpdate has passed, or it is the first scan); otherwise that was all;
3. processing: each particle scan-matches against its own map (:mod:`gmapping.scan_matcher`), keeps the
   matched pose when the score beats minimumScore, and adds the scan's likelihood to its weight;
4. the weights are normalised and the effective sample size N_eff computed
   (:mod:`gmapping.resampling`); below resampleThreshold x N the set is resampled systematically
   (the copies share their parent's map and trajectory) and the weights restart at zero;
5. every particle adds the scan to its map at its pose and its pose to its trajectory.

The best particle is the one with the largest weight summed over all updates (never reset); the map
published is built from its trajectory and the stored scans (:mod:`gmapping.occupancy`).

Poses are of the robot's base frame (x [m], y [m], yaw [rad]) in the map frame; the map frame starts
on the odometry frame (the particles start at the first scan's odometry pose), as in slam_gmapping.
"""

import logging
import math
from dataclasses import dataclass

import numpy as np

from florence_common import angles
from florence_common.pose import compose, inverse
from gmapping.laser import usable_ranges
from gmapping.motion import sample_motion
from gmapping.occupancy import OccupancyCounts
from gmapping.params import SLAM
from gmapping.particle_maps import ParticleMaps
from gmapping.resampling import entropy, normalise, systematic
from gmapping.scan_matcher import MatchSettings, match

log = logging.getLogger(__name__)

ODOMETRY_JUMP = 20.0  # [m] a step this long between processed scans is reported (GMapping's check)


@dataclass
class SlamConfig:
    """slam_gmapping's mapper parameters (gmapping.params.SLAM: names, defaults, units)."""

    particles: int = 30
    maxRange: float | None = None  # [m] None: the scan's range_max - 0.01
    maxUrange: float | None = None  # [m] None: maxRange
    sigma: float = 0.05
    kernelSize: int = 1
    lstep: float = 0.05
    astep: float = 0.05
    iterations: int = 5
    lsigma: float = 0.075
    ogain: float = 3.0
    lskip: int = 0
    minimumScore: float = 0.0
    srr: float = 0.1
    srt: float = 0.2
    str: float = 0.1
    stt: float = 0.2
    linearUpdate: float = 1.0
    angularUpdate: float = 0.5
    temporalUpdate: float = -1.0
    resampleThreshold: float = 0.5
    xmin: float = -100.0
    ymin: float = -100.0
    xmax: float = 100.0
    ymax: float = 100.0
    delta: float = 0.05
    occ_thresh: float = 0.25

    def validate(self):
        """ValueError naming what is wrong (the ranges of each parameter are checked by SLAM)."""
        if not (self.xmin < self.xmax and self.ymin < self.ymax):
            raise ValueError(f"~xmin < ~xmax and ~ymin < ~ymax needed, got x {self.xmin}..{self.xmax}, "
                             f"y {self.ymin}..{self.ymax}")
        return self

    def ranges_for(self, range_max):
        """(maxRange, maxUrange) [m] for a laser of ``range_max`` [m], with slam_gmapping's defaults."""
        max_range = self.maxRange if self.maxRange is not None else range_max - 0.01
        usable = self.maxUrange if self.maxUrange is not None else max_range
        return float(max_range), float(usable)


def config_from_params(get):
    """SlamConfig from slam_gmapping's parameters: ``get(name, default)`` (rospy.get_param with "~", or a
    launch file's values). Raises ValueError naming a bad parameter."""
    p = SLAM.read(get)
    return SlamConfig(**{k: p[k] for k in SlamConfig.__dataclass_fields__}).validate()


@dataclass
class ScanResult:
    processed: bool = False  # the scan was matched and added to the maps
    resampled: bool = False
    neff: float = math.nan  # effective sample size after the update
    matched: float = math.nan  # mean fraction of the used beams that found a surface, over the particles
    failed_matches: int = 0  # particles whose scan matching fell short of minimumScore
    odometry_jump: bool = False


class GridSlam:
    """The mapper. ``odom_pose`` (x, y, yaw): the base's odometry pose at the first scan, where the
    particles start; ``rng``: numpy Generator."""

    def __init__(self, config, odom_pose, rng=None):
        self.cfg = config.validate()
        self.rng = rng if rng is not None else np.random.default_rng()
        n = self.cfg.particles
        self.poses = np.tile(np.asarray(odom_pose, dtype=float), (n, 1))
        self.weights = np.zeros(n)  # log-likelihood since the last resampling
        self.weight_sums = np.zeros(n)  # log-likelihood over every update (the best particle's measure)
        self.maps = ParticleMaps(n, self.cfg.delta)
        self.match_settings = MatchSettings(self.cfg.sigma, self.cfg.kernelSize, self.cfg.lstep, self.cfg.astep,
                                            self.cfg.iterations, self.cfg.lsigma, self.cfg.lskip,
                                            self.cfg.minimumScore)
        self.trajectories = np.zeros((n, 64, 3))  # [particle, update, pose]
        self.scans = []  # per update: (laser geometry, ranges [B] with inf for no reading, usable, max_range)
        self.stamps = []  # per update: the scan's time [s]
        self.updates = 0
        self.resamplings = 0
        self.neff = float(n)
        self.normalised = np.full(n, 1.0 / n)
        self.last_odom = None  # odometry pose of the previous scan
        self.distance = 0.0  # [m] travelled since the last processed scan
        self.rotation = 0.0  # [rad] turned since then
        self.last_update_time = None
        self._counts = None  # OccupancyCounts of the best trajectory so far
        self._counts_trajectory = np.zeros((0, 3))

    # ---- the filter ----------------------------------------------------------------------------------
    def process_scan(self, odom_pose, laser, ranges, range_min, range_max, stamp):
        """One scan: ``odom_pose`` (x, y, yaw) of the base at the scan's time, ``laser`` a LaserGeometry,
        ``ranges`` [B] [m] as the LaserScan has them (NaN, inf, readings out of range: no reading),
        ``range_min`` and ``range_max`` the scan's [m], ``stamp`` its time [s]. Returns a ScanResult."""
        cfg = self.cfg
        odom_pose = np.asarray(odom_pose, dtype=float)
        result = ScanResult()
        if self.last_odom is not None:
            self.poses = sample_motion(self.poses, odom_pose, self.last_odom, cfg.srr, cfg.srt, cfg.str, cfg.stt,
                                       self.rng)
            self.distance += float(np.hypot(*(odom_pose[:2] - self.last_odom[:2])))
            self.rotation += abs(angles.diff(float(odom_pose[2]), float(self.last_odom[2])))
        self.last_odom = odom_pose
        if self.distance > ODOMETRY_JUMP:
            result.odometry_jump = True
            log.warning("the odometry has a big jump here: %.1f m since the last processed scan", self.distance)
        due = (self.updates == 0 or self.distance >= cfg.linearUpdate or self.rotation >= cfg.angularUpdate
               or (cfg.temporalUpdate >= 0 and stamp - self.last_update_time > cfg.temporalUpdate))
        if not due:
            return result
        max_range, usable = cfg.ranges_for(range_max)
        ranges = usable_ranges(ranges, range_min, max_range)
        self._cover(laser, ranges, usable)
        if self.updates == 0:
            # every particle is at the same pose: one registration, shared by all
            self.maps.register(self.poses[:1], laser, ranges, usable)
            self.maps.share(0)
        else:
            poses, scores, likelihood, matched = match(self.maps, self.poses, laser, ranges, usable,
                                                       self.match_settings)
            self.poses = poses
            result.failed_matches = int(np.count_nonzero(scores <= cfg.minimumScore))
            used = np.count_nonzero(ranges[cfg.lskip::cfg.lskip + 1] <= usable)
            result.matched = float(np.mean(matched) / used) if used else 0.0
            self.weights += likelihood
            self.weight_sums += likelihood
            self.normalised, self.neff = normalise(self.weights, cfg.ogain)
            if self.neff < cfg.resampleThreshold * cfg.particles:
                parents = systematic(self.normalised, self.rng)
                self.poses = self.poses[parents]
                self.weights = np.zeros(cfg.particles)
                self.weight_sums = self.weight_sums[parents]
                self.trajectories = self.trajectories[parents]
                self.maps.resample(parents)
                self.normalised = np.full(cfg.particles, 1.0 / cfg.particles)
                self.resamplings += 1
                result.resampled = True
            self.maps.register(self.poses, laser, ranges, usable)
        self._append(laser, ranges, usable, max_range, stamp)
        self.distance = self.rotation = 0.0
        self.last_update_time = stamp
        result.processed = True
        result.neff = self.neff
        return result

    def _cover(self, laser, ranges, usable):
        """Grow the particles' maps to hold this scan's end points from every particle."""
        use = ranges <= usable
        if not use.any():
            return
        reach = float(ranges[use].max()) + math.hypot(laser.x, laser.y) + 0.5  # + the matcher's moves
        lo, hi = self.poses[:, :2].min(axis=0) - reach, self.poses[:, :2].max(axis=0) + reach
        self.maps.cover(lo[0], lo[1], hi[0], hi[1])

    def _append(self, laser, ranges, usable, max_range, stamp):
        if self.updates == self.trajectories.shape[1]:
            self.trajectories = np.concatenate([self.trajectories, np.zeros_like(self.trajectories)], axis=1)
        self.trajectories[:, self.updates] = self.poses
        self.scans.append((laser, np.asarray(ranges, np.float32), usable, max_range))
        self.stamps.append(float(stamp))
        self.updates += 1

    # ---- results -------------------------------------------------------------------------------------
    @property
    def best(self):
        """Index of the best particle: the largest summed log-likelihood."""
        return int(np.argmax(self.weight_sums))

    def best_pose(self):
        return tuple(float(v) for v in self.poses[self.best])

    def best_trajectory(self):
        """(stamps [T] [s], poses [T, 3]) of the best particle at every processed scan."""
        return np.array(self.stamps), self.trajectories[self.best, :self.updates].copy()

    def map_to_odom(self, odom_pose):
        """map -> odom (x, y, yaw): the best particle's pose composed with the inverse odometry pose."""
        return compose(self.best_pose(), inverse(tuple(float(v) for v in odom_pose)))

    def entropy(self):
        """Entropy [nats] of the particles' normalised weights."""
        return entropy(self.normalised)

    def build_map(self):
        """(data [H, W] int8 (-1, 0, 100; rows are y), origin (x, y) [m], resolution [m/cell]) of the best
        particle's trajectory. The counts carry over while the best particle's history stays the same; a
        new history is rebuilt from scratch."""
        cfg = self.cfg
        trajectory = self.trajectories[self.best, :self.updates]
        done = len(self._counts_trajectory)
        if self._counts is None or done > len(trajectory) or not np.array_equal(trajectory[:done],
                                                                               self._counts_trajectory):
            self._counts, done = OccupancyCounts(cfg.delta), 0
        for k in range(done, len(trajectory)):
            laser, ranges, usable, max_range = self.scans[k]
            self._counts.add_scan(trajectory[k], laser, ranges, usable, max_range)
        self._counts_trajectory = trajectory.copy()
        bounds = (np.floor(np.array([cfg.xmin, cfg.ymin]) / cfg.delta).astype(np.int64),
                  np.floor(np.array([cfg.xmax, cfg.ymax]) / cfg.delta).astype(np.int64) - 1)
        data, origin = self._counts.grid(cfg.occ_thresh, bounds)
        return data, origin, cfg.delta

    def memory_bytes(self):
        """Bytes held by the maps, trajectories and stored scans (the process has more)."""
        lasers = {id(s[0]): s[0].cos.nbytes + s[0].sin.nbytes for s in self.scans}
        scans = sum(s[1].nbytes for s in self.scans) + sum(lasers.values())
        counts = 0 if self._counts is None else self._counts.hits.nbytes * 2
        return self.maps.nbytes() + self.trajectories.nbytes + scans + counts


def warm_up():
    """Compile (or load from numba's cache) every kernel the mapper uses, on a tiny synthetic scan, so that the
    first real scans are not held up by the compiler (tens of seconds on a busy machine). Returns the seconds
    it took."""
    import time

    from gmapping.laser import LaserGeometry

    started = time.monotonic()
    angles = np.linspace(-1.5, 1.5, 31)
    ranges = np.where(np.abs(np.tan(angles)) < 2.0, 2.0 / np.cos(angles), np.inf)  # a wall 2 m ahead
    laser = LaserGeometry.from_transform(np.eye(4), angles[0], angles[1] - angles[0], len(angles))
    config = SlamConfig(particles=2, linearUpdate=0.0, angularUpdate=0.0, xmin=-1.0, ymin=-1.0, xmax=1.0, ymax=1.0)
    slam = GridSlam(config, (0.0, 0.0, 0.0), np.random.default_rng(0))
    for x in (0.0, 0.05):
        slam.process_scan((x, 0.0, 0.0), laser, ranges - x, 0.02, 5.6, x)
    slam.build_map()
    return time.monotonic() - started
