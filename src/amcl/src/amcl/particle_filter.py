"""The particle filter of ROS amcl (its ``pf`` library), vectorised with numpy.

Particles are an array [N, 3] of (x [m], y [m], yaw [rad]) with weights [N] summing to 1.

- Sensor update (``update_sensor``): weights times the sensor model's p, normalised; the
  average unnormalised weight feeds the slow and fast averages of Augmented MCL
  (``w_slow += alpha_slow (w_avg - w_slow)``, same for fast).
- Resampling (``resample``) with KLD-sampling: draws one particle at a time (multinomial
  on the weights, or a uniformly random free pose with probability
  ``max(0, 1 - w_fast / w_slow)``), puts it into a histogram of 0.5 m x 0.5 m x 10 deg
  bins, and stops once the count exceeds ``kld_limit(k)`` for the k occupied bins. As in
  ROS, ``kld_z`` is used as the normal quantile itself (ROS passes the 0.99 straight in).
  The draw is vectorised: max_particles candidates are drawn at once and the sequential
  stopping rule is applied to their running bin count, which gives the same distribution.
- ``recovery_wait_converged`` (Florence addition): after an initialisation the averages start with
  the first update of a converged set. Seeded by a set spread over the map (global localization),
  ``w_slow`` (alpha 0.001) stays at the spread set's low likelihood for hundreds of updates, so a
  set that converged on a wrong pose always looks better than average and no random pose is drawn.
- Pose estimate (``estimate``): particles clustered by connected occupied histogram bins
  (yaw wraps around), the heaviest cluster's weighted mean (circular mean for yaw), and
  the covariance of the whole set (x/y block; yaw variance ``-2 ln |mean unit vector|``).
"""

import logging
import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from florence_common import angles

log = logging.getLogger(__name__)

BIN_SIZE = (0.5, 0.5, math.radians(10.0))  # histogram bins of KLD-sampling and clustering [m, m, rad]
MAX_CLUSTER_GRID = 4_000_000  # bins of the dense clustering grid (a 180 m x 180 m spread)
CONVERGED_DIST = 0.5  # [m] ROS pf's dist_threshold: converged when every particle is this close to the mean


@dataclass
class FilterParams:
    min_particles: int = 100
    max_particles: int = 5000
    kld_err: float = 0.01
    kld_z: float = 0.99
    recovery_alpha_slow: float = 0.0
    recovery_alpha_fast: float = 0.0
    resample_interval: int = 2
    selective_resampling: bool = False
    # Florence addition: Augmented MCL's w_avg as the set's mean likelihood sum(w p) (Probabilistic
    # Robotics table 8.3) instead of ROS's sum(w p) / N, which scales with 1/N (False: ROS).
    recovery_mean_likelihood: bool = False
    # Florence addition: the recovery averages start only once the set has converged (every particle within
    # CONVERGED_DIST of the weighted mean in x and in y, ROS's pf convergence test) after an initialisation,
    # instead of from the first update of a spread set (False: ROS).
    recovery_wait_converged: bool = False

    def validate(self):
        """Raise ValueError naming the parameter that is out of range."""
        if not 1 <= self.min_particles <= self.max_particles:
            raise ValueError(f"need 1 <= min_particles ({self.min_particles}) <= max_particles ({self.max_particles})")
        if not 0.0 < self.kld_err < 1.0:
            raise ValueError(f"kld_err must be in (0, 1), got {self.kld_err}")
        if not self.kld_z > 0.0:
            raise ValueError(f"kld_z must be > 0, got {self.kld_z}")
        for name in ("recovery_alpha_slow", "recovery_alpha_fast"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        if self.resample_interval < 1:
            raise ValueError(f"resample_interval must be >= 1, got {self.resample_interval}")


def kld_limit(k, kld_err, kld_z, min_particles, max_particles):
    """Particles needed for k occupied bins (Fox 2003, as ROS pf_resample_limit); works on arrays."""
    k = np.asarray(k, dtype=float)
    km1 = np.maximum(k - 1.0, 1.0)
    b = 2.0 / (9.0 * km1)
    x = 1.0 - b + np.sqrt(b) * kld_z
    n = np.ceil(km1 / (2.0 * kld_err) * x**3)
    n = np.where(k <= 1, max_particles, np.clip(n, min_particles, max_particles))
    return n.astype(np.int64)


def bin_keys(particles):
    """Integer histogram bin (ix, iy, iyaw) of each particle [N, 3]; yaw normalised first."""
    scaled = np.column_stack([particles[:, 0], particles[:, 1], angles.wrap(particles[:, 2])]) / BIN_SIZE
    return np.floor(scaled).astype(np.int64)


def running_bin_count(keys):
    """k[i] = number of distinct bins among keys[0..i]."""
    _, first = np.unique(keys, axis=0, return_index=True)
    new = np.zeros(len(keys), dtype=np.int64)
    new[first] = 1
    return np.cumsum(new)


def cluster_labels(particles):
    """Cluster id (0..C-1) of every particle: connected occupied bins, 26-neighbourhood, yaw wraps."""
    keys = bin_keys(particles)
    lo = keys.min(axis=0)
    n_yaw = math.ceil(2.0 * math.pi / BIN_SIZE[2])
    yaw_lo = math.floor(-math.pi / BIN_SIZE[2])
    idx = keys - np.array([lo[0], lo[1], yaw_lo])
    idx[:, 2] = np.clip(idx[:, 2], 0, n_yaw - 1)
    shape = (idx[:, 0].max() + 1, idx[:, 1].max() + 1, n_yaw)
    if shape[0] * shape[1] * shape[2] > MAX_CLUSTER_GRID:  # a wildly spread set: one cluster
        log.debug("particles spread over %s bins: not clustering", shape)
        return np.zeros(len(particles), dtype=np.int64)
    grid = np.zeros(shape, dtype=bool)
    grid[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    labels, count = ndimage.label(grid, structure=np.ones((3, 3, 3), dtype=bool))
    # Join clusters across the yaw seam (-pi / pi) with a small union-find on label pairs.
    parent = np.arange(count + 1)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    first, last = labels[:, :, 0], labels[:, :, -1]
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            shifted = np.roll(np.roll(last, dx, axis=0), dy, axis=1)
            # np.roll wraps around x/y too; blank the rows/columns that came round.
            if dx > 0:
                shifted[:dx, :] = 0
            elif dx < 0:
                shifted[dx:, :] = 0
            if dy > 0:
                shifted[:, :dy] = 0
            elif dy < 0:
                shifted[:, dy:] = 0
            both = (first > 0) & (shifted > 0)
            for a, b in zip(first[both], shifted[both], strict=True):
                ra, rb = find(a), find(b)
                if ra != rb:
                    parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(i) for i in range(count + 1)])
    per_particle = roots[labels[idx[:, 0], idx[:, 1], idx[:, 2]]]
    _, dense = np.unique(per_particle, return_inverse=True)
    return dense


def weighted_mean(particles, weights):
    """(x, y, yaw) weighted mean; yaw by the circular mean."""
    w = weights / weights.sum()
    return np.array([np.dot(w, particles[:, 0]), np.dot(w, particles[:, 1]), angles.circular_mean(particles[:, 2], w)])


def weighted_covariance(particles, weights):
    """3x3 covariance: the x/y block and the circular yaw variance -2 ln R (no x/y-yaw terms, like ROS)."""
    w = weights / weights.sum()
    mean = weighted_mean(particles, weights)
    d = particles[:, :2] - mean[:2]
    cov = np.zeros((3, 3))
    cov[:2, :2] = (d * w[:, None]).T @ d
    r = math.hypot(np.dot(w, np.sin(particles[:, 2])), np.dot(w, np.cos(particles[:, 2])))
    cov[2, 2] = -2.0 * math.log(max(r, 1e-12))
    return cov


class ParticleFilter:
    """Adaptive (KLD-sampling) Monte Carlo localization filter with Augmented-MCL recovery."""

    def __init__(self, params=None, rng=None):
        self.params = params or FilterParams()
        self.params.validate()
        self.rng = np.random.default_rng() if rng is None else rng
        self.particles = np.zeros((1, 3))
        self.weights = np.ones(1)
        self.w_slow = 0.0
        self.w_fast = 0.0
        self.n_effective = 1.0
        self.waiting = True

    def __len__(self):
        return len(self.particles)

    def _reset(self, particles):
        self.particles = particles
        self.weights = np.full(len(particles), 1.0 / len(particles))
        self.w_slow = self.w_fast = 0.0
        self.waiting = True  # recovery_wait_converged: no averages until the set has converged

    def converged(self):
        """True when every particle is within CONVERGED_DIST [m] of the weighted mean in x and in y (ROS)."""
        mean = self.weights @ self.particles[:, :2]
        return bool(np.all(np.abs(self.particles[:, :2] - mean) <= CONVERGED_DIST))

    def init_gaussian(self, mean, cov):
        """max_particles particles from N(mean, cov) (3x3, x/y/yaw) like ROS pf_init."""
        cov = np.asarray(cov, dtype=float)
        # Eigen-decomposition sampling tolerates a singular (e.g. zero) covariance.
        vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
        noise = self.rng.normal(size=(self.params.max_particles, 3)) * np.sqrt(np.clip(vals, 0.0, None))
        particles = np.asarray(mean, dtype=float) + noise @ vecs.T
        particles[:, 2] = angles.wrap(particles[:, 2])
        self._reset(particles)

    def init_uniform(self, omap):
        """max_particles particles uniform over the map's free space (global localization)."""
        self._reset(omap.random_free_poses(self.params.max_particles, self.rng))

    def update_sensor(self, likelihoods):
        """Multiply the weights by the sensor model's p [N]; normalise; update w_slow / w_fast."""
        likelihoods = np.asarray(likelihoods, dtype=float)
        raw = self.weights * likelihoods
        total = raw.sum()
        if not (math.isfinite(total) and total > 0.0):
            log.warning("sensor update gave total weight %r: weights reset to uniform", total)
            self.weights = np.full(len(self), 1.0 / len(self))
            self.n_effective = float(len(self))
            return
        self.weights = raw / total
        self.n_effective = 1.0 / float(np.sum(self.weights**2))
        p = self.params
        if p.recovery_wait_converged and self.waiting:
            if not self.converged():
                return
            self.waiting = False
        w_avg = total if p.recovery_mean_likelihood else total / len(self)
        self.w_slow = w_avg if self.w_slow == 0.0 else self.w_slow + p.recovery_alpha_slow * (w_avg - self.w_slow)
        self.w_fast = w_avg if self.w_fast == 0.0 else self.w_fast + p.recovery_alpha_fast * (w_avg - self.w_fast)

    def random_fraction(self):
        """Probability that a resampled particle is a random pose: max(0, 1 - w_fast / w_slow)."""
        if self.w_slow <= 0.0:
            return 0.0
        return max(0.0, 1.0 - self.w_fast / self.w_slow)

    def resample(self, omap=None):
        """KLD-sampling resampling with random-pose injection (needs ``omap`` for the random poses).

        Returns False when selective resampling kept the set (N_eff above half the count).
        """
        p = self.params
        if p.selective_resampling and self.n_effective > 0.5 * len(self):
            return False
        n_max = p.max_particles
        w_diff = self.random_fraction() if omap is not None and omap.has_free_cells else 0.0
        cum = np.cumsum(self.weights)
        cum[-1] = 1.0
        picks = np.minimum(np.searchsorted(cum, self.rng.random(n_max), side="right"), len(self) - 1)
        candidates = self.particles[picks].copy()
        if w_diff > 0.0:
            random = self.rng.random(n_max) < w_diff
            if random.any():
                candidates[random] = omap.random_free_poses(int(random.sum()), self.rng)
        k = running_bin_count(bin_keys(candidates))
        limits = kld_limit(k, p.kld_err, p.kld_z, p.min_particles, n_max)
        counts = np.arange(1, n_max + 1)
        over = np.nonzero(counts > limits)[0]
        n = int(over[0]) + 1 if over.size else n_max
        self.particles = candidates[:n]
        self.weights = np.full(n, 1.0 / n)
        if w_diff > 0.0:  # ROS resets the averages so it does not spiral into randomness
            self.w_slow = self.w_fast = 0.0
        return True

    def predict(self, motion):
        """Apply a motion function particles [N, 3] -> particles [N, 3]."""
        self.particles = motion(self.particles)

    def estimate(self):
        """(mean of the heaviest cluster (x, y, yaw), 3x3 covariance of the set, cluster count)."""
        labels = cluster_labels(self.particles)
        totals = np.bincount(labels, weights=self.weights)
        best = int(np.argmax(totals))
        members = labels == best
        mean = weighted_mean(self.particles[members], self.weights[members])
        return mean, weighted_covariance(self.particles, self.weights), len(totals)
