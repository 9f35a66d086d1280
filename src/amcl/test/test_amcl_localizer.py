"""The update cycle: when the filter moves, weighs and resamples; tracking and global localization
on a synthetic map with simulated scans; bad scans skipped."""

import math

import numpy as np
import pytest
from amcl.localizer import AmclConfig, Localizer, map_to_odom
from amcl.particle_filter import FilterParams
from amcl.sensor import OccupancyMap

from florence_common import angles

pytestmark = pytest.mark.unit

RES = 0.05
LASER_XY = np.array([0.06, 0.0])
BEARINGS = -np.linspace(-2.0862, 2.0862, 683)  # upside-down URG: reversed order


def flat_map():
    """8 m x 6 m, origin (0, 0): outer walls, an L-shaped wall and two boxes (no symmetry)."""
    data = np.zeros((120, 160), dtype=np.int8)
    data[:2, :] = data[-2:, :] = 100
    data[:, :2] = data[:, -2:] = 100
    data[60:62, 0:70] = 100        # wall at y = 3.0 from x = 0 to 3.5
    data[60:100, 68:70] = 100      # and up at x = 3.4
    data[20:30, 110:125] = 100     # box at x 5.5..6.25, y 1.0..1.5
    data[85:100, 120:124] = 100    # post at x 6.0..6.2, y 4.25..5.0
    return data


def simulate_scan(omap, pose, noise=0.0, rng=None):
    c, s = math.cos(pose[2]), math.sin(pose[2])
    lx = pose[0] + c * LASER_XY[0] - s * LASER_XY[1]
    ly = pose[1] + s * LASER_XY[0] + c * LASER_XY[1]
    r = omap.calc_range(np.full(BEARINGS.shape, lx), np.full(BEARINGS.shape, ly), pose[2] + BEARINGS, 5.6)
    if noise:
        r = r + rng.normal(0.0, noise, r.shape)
    return r


def make_localizer(**filter_kw):
    config = AmclConfig(filter=FilterParams(**{"min_particles": 500, "max_particles": 2000, "kld_err": 0.05,
                                               "resample_interval": 1, **filter_kw}),
                        laser_max_beams=60, odom_model_type="diff-corrected",
                        odom_alphas=(0.05, 0.05, 0.05, 0.05, 0.05), update_min_d=0.1, update_min_a=0.2)
    loc = Localizer(config, np.random.default_rng(4))
    loc.set_map(flat_map(), RES, (0.0, 0.0))
    return loc


def test_first_scan_updates_then_only_after_motion():
    loc = make_localizer()
    loc.set_pose([2.0, 1.5, 0.0], np.diag([0.01, 0.01, 0.01]))
    ranges = simulate_scan(loc.map, [2.0, 1.5, 0.0])
    odom = np.array([10.0, 10.0, 1.0])
    assert loc.process_scan(odom, LASER_XY, BEARINGS, ranges, 0.02, 5.6).updated
    assert not loc.process_scan(odom, LASER_XY, BEARINGS, ranges, 0.02, 5.6).updated
    # per axis thresholds: 0.08 in x and 0.08 in y is 0.11 in distance but below 0.1 on each axis
    assert not loc.process_scan(odom + np.array([0.08, 0.08, 0]), LASER_XY, BEARINGS, ranges, 0.02, 5.6).updated
    assert loc.process_scan(odom + np.array([0.11, 0, 0]), LASER_XY, BEARINGS, ranges, 0.02, 5.6).updated
    assert loc.process_scan(odom + np.array([0.11, 0, 0.21]), LASER_XY, BEARINGS, ranges, 0.02, 5.6).updated
    loc.request_nomotion_update()
    assert loc.process_scan(odom + np.array([0.11, 0, 0.21]), LASER_XY, BEARINGS, ranges, 0.02, 5.6).updated


def test_resample_interval_counts_updates():
    loc = make_localizer(resample_interval=3)
    loc.set_pose([2.0, 1.5, 0.0], np.diag([0.01, 0.01, 0.01]))
    ranges = simulate_scan(loc.map, [2.0, 1.5, 0.0])
    flags = []
    for _ in range(6):
        loc.request_nomotion_update()
        flags.append(loc.process_scan(np.array([0.0, 0.0, 0.0]), LASER_XY, BEARINGS, ranges, 0.02, 5.6).resampled)
    assert flags == [False, False, True, False, False, True]


def test_selective_resampling_still_reports_every_interval():
    """Regression: with selective_resampling the node published amcl_pose only when the set was actually
    resampled (rarely, once converged); ROS sets its "resampled" flag every resample_interval updates."""
    loc = make_localizer(resample_interval=2, selective_resampling=True)
    loc.set_pose([2.0, 1.5, 0.0], np.diag([0.01, 0.01, 0.01]))
    ranges = np.full(BEARINGS.shape, 5.6)  # no returns: every particle weighs the same, N_eff = N
    flags = []
    for _ in range(6):
        loc.request_nomotion_update()
        flags.append(loc.process_scan(np.array([0.0, 0.0, 0.0]), LASER_XY, BEARINGS, ranges, 0.02, 5.6).resampled)
    assert flags == [False, True, False, True, False, True]
    assert len(loc.pf) == 2000  # the set was kept (not resampled down to the KLD bound)


@pytest.mark.parametrize(("ranges", "reason"), [
    (np.array([]), "0 ranges"),
    (np.full(683, np.nan), "only NaN"),
])
def test_bad_scans_are_skipped(ranges, reason):
    loc = make_localizer()
    loc.set_pose([2.0, 1.5, 0.0], np.diag([0.01, 0.01, 0.01]))
    before = loc.pf.particles.copy()
    bearings = BEARINGS if len(ranges) else np.array([])
    result = loc.process_scan(np.zeros(3), LASER_XY, bearings, ranges, 0.02, 5.6)
    assert not result.updated and reason in result.reason
    np.testing.assert_array_equal(loc.pf.particles, before)


def test_map_without_free_cells_is_skipped():
    loc = make_localizer()
    loc.set_map(np.full((10, 10), 100, dtype=np.int8), 0.1, (0.0, 0.0))
    loc.set_pose([0.5, 0.5, 0.0], np.eye(3) * 0.01)
    result = loc.process_scan(np.zeros(3), LASER_XY, BEARINGS, np.ones(683), 0.02, 5.6)
    assert not result.updated and "no free cells" in result.reason
    with pytest.raises(ValueError, match="free cells"):
        loc.global_localization()


def test_short_readings_count_as_max_range():
    loc = make_localizer()
    loc.config.laser_min_range = 0.1
    loc.config.laser_max_range = 4.0
    ranges, range_max = loc.laser_ranges(np.array([0.01, 0.05, 0.5, 5.0]), 0.02, 5.6)
    assert range_max == 4.0
    assert ranges.tolist() == [4.0, 4.0, 0.5, 5.0]


def drive(loc, start_pose, steps, rng, odom_noise=0.01, scan_noise=0.01):
    """Drive a path of (v [m/step], w [rad/step]) steps; returns errors (position, yaw) after each update."""
    true = np.array(start_pose, dtype=float)
    odom = np.array([1.0, -2.0, 0.3])  # odometry frame deliberately not the map frame
    errors = []
    for v, w in steps:
        true = true + np.array([v * math.cos(true[2] + w / 2), v * math.sin(true[2] + w / 2), w])
        vo, wo = v * (1 + rng.normal(0, odom_noise)), w * (1 + rng.normal(0, odom_noise))
        odom = odom + np.array([vo * math.cos(odom[2] + wo / 2), vo * math.sin(odom[2] + wo / 2), wo])
        scan = simulate_scan(loc.map, true, scan_noise, rng)
        result = loc.process_scan(odom, LASER_XY, BEARINGS, scan, 0.02, 5.6)
        if result.updated:
            errors.append((math.hypot(*(result.pose[:2] - true[:2])), abs(angles.diff(result.pose[2], true[2]))))
    return np.array(errors), true


TOUR = [(0.05, 0.0)] * 50 + [(0.0, 0.1)] * 16 + [(0.05, 0.0)] * 30 + [(0.03, -0.05)] * 20


def test_tracking_on_synthetic_map():
    rng = np.random.default_rng(9)
    loc = make_localizer()
    start = [1.0, 1.0, 0.0]
    loc.set_pose(start, np.diag([0.04, 0.04, 0.02]))
    errors, _ = drive(loc, start, TOUR, rng)
    settled = errors[5:]
    assert np.sqrt(np.mean(settled[:, 0] ** 2)) < 0.05
    assert np.degrees(np.sqrt(np.mean(settled[:, 1] ** 2))) < 2.0


def test_global_localization_converges():
    rng = np.random.default_rng(10)
    loc = make_localizer(max_particles=5000)
    loc.global_localization()
    assert len(loc.pf) == 5000
    errors, _ = drive(loc, [1.0, 1.0, 0.0], TOUR, rng)
    assert errors[-1, 0] < 0.1 and errors[-1, 1] < math.radians(5)
    assert len(loc.pf) < 1000  # KLD shrank the set once it converged


def test_map_to_odom_composes():
    map_pose = np.array([2.0, 1.0, 0.5])
    odom_pose = np.array([1.0, -2.0, 0.3])
    t = map_to_odom(map_pose, odom_pose)
    c, s = math.cos(t[2]), math.sin(t[2])
    # map_T_odom * odom_pose == map_pose
    assert t[0] + c * odom_pose[0] - s * odom_pose[1] == pytest.approx(map_pose[0])
    assert t[1] + s * odom_pose[0] + c * odom_pose[1] == pytest.approx(map_pose[1])
    assert angles.diff(t[2] + odom_pose[2], map_pose[2]) == pytest.approx(0.0)


def test_occupancy_map_rejects_bad_maps():
    with pytest.raises(ValueError, match="resolution"):
        OccupancyMap(np.zeros((3, 3)), 0.0, (0, 0))
    with pytest.raises(ValueError, match="non-empty"):
        OccupancyMap(np.zeros((0, 3)), 0.1, (0, 0))


def test_off_free_weight_penalises_particles_in_walls():
    loc = make_localizer()
    loc.config.off_free_weight = 0.01
    loc.set_pose([2.0, 1.5, 0.0], np.diag([0.01, 0.01, 0.01]))
    loc.pf.particles[:10, :2] = [0.02, 0.02]  # inside the outer wall
    loc.pf.particles[10:20, :2] = [-5.0, -5.0]  # off the map
    ranges = simulate_scan(loc.map, [2.0, 1.5, 0.0])
    loc.config.filter.resample_interval = 1000  # keep the weights to look at them
    loc.process_scan(np.zeros(3), LASER_XY, BEARINGS, ranges, 0.02, 5.6)
    w = loc.pf.weights
    assert w[:20].max() < 0.05 * w[20:].min()


def test_bad_config_is_named():
    with pytest.raises(ValueError, match="off_free_weight"):
        AmclConfig(off_free_weight=2.0).validate()
    with pytest.raises(ValueError, match="odom_alpha3"):
        AmclConfig(odom_alphas=(0.1, 0.1, -1.0, 0.1, 0.1)).validate()
    with pytest.raises(ValueError, match="laser_model_type"):
        AmclConfig(laser_model_type="likelihood_field_probability").validate()
