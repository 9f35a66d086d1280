"""The mapper on synthetic scans: a drive around a loop of corridors with drifting odometry."""

import itertools
import math

import numpy as np
import pytest
from gmapping.laser import LaserGeometry
from gmapping.slam import GridSlam, SlamConfig, config_from_params

from florence_common import angles, pose
from florence_harness import laser_scenes

pytestmark = pytest.mark.unit

WORLD = laser_scenes.corridor_loop()
LOOP = [(7.25, 0.75), (7.25, 7.25), (0.75, 7.25), (0.75, 0.75), (4.0, 0.75)]
# the shipped launch file's mapper values that matter here (particles fewer: a unit test)
CONFIG = dict(particles=10, sigma=0.005, srr=0.01, srt=0.02, str=0.01, stt=0.02, linearUpdate=0.5,
              angularUpdate=0.436, xmin=-1.0, ymin=-1.0, xmax=1.0, ymax=1.0)


def drive(start, waypoints, v=0.4, w=1.0, dt=0.1):
    """True poses every dt [s] along the waypoints: turn on the spot, then straight."""
    x, y, yaw = start
    out = [(x, y, yaw)]
    for tx, ty in waypoints:
        heading = math.atan2(ty - y, tx - x)
        while abs(angles.diff(heading, yaw)) > 1e-9:
            yaw = angles.wrap(yaw + max(-w * dt, min(w * dt, angles.diff(heading, yaw))))
            out.append((x, y, yaw))
        dist = math.hypot(tx - x, ty - y)
        for k in range(1, math.ceil(dist / (v * dt)) + 1):
            s = min(1.0, k * v * dt / dist)
            out.append((x + s * (tx - x), y + s * (ty - y), yaw))
        x, y = tx, ty
    return np.array(out)


def odometry(truth, scale=1.02, gyro=1.03):
    """Odometry of the true poses with a distance scale error and a gyro scale error, starting at 0."""
    odom = [np.zeros(3)]
    for a, b in itertools.pairwise(truth):
        step = np.array(pose.relative(a, b)) * [scale, scale, gyro]
        odom.append(np.array(pose.compose(odom[-1], step)))
    return np.array(odom)


def run(config, laser=laser_scenes.UPSIDE_DOWN, seed=1, waypoints=LOOP, readings=None):
    """GridSlam over the drive; returns (slam, truth poses, odometry poses) (poses of every scan)."""
    start = (0.75, 0.75, 0.0)
    truth = drive(start, waypoints)
    odom = odometry(truth)
    slam = None
    for k, (t, o) in enumerate(zip(truth, odom, strict=True)):
        # the same noisy readings for either mounting: an upside-down laser reports them in reverse order
        ranges, angle_min, inc = laser_scenes.scan(WORLD, t, laser=laser_scenes.UPRIGHT, noise=0.01,
                                                   rng=np.random.default_rng(k))
        if laser is laser_scenes.UPSIDE_DOWN:
            ranges = ranges[::-1].copy()
        if readings is not None:
            ranges = readings(k, ranges)
        geometry = LaserGeometry.from_transform(laser, angle_min, inc, len(ranges))
        if slam is None:
            slam = GridSlam(config, o, np.random.default_rng(seed))
        slam.process_scan(o, geometry, ranges, 0.02, 5.6, 0.1 * k)
    return slam, truth, odom


def in_world(slam, truth):
    """The best trajectory in the world frame (the map frame starts at the first true pose)."""
    _, trajectory = slam.best_trajectory()
    return np.array(pose.compose(truth[0], trajectory))


@pytest.fixture(scope="module")
def mapped():
    return run(SlamConfig(**CONFIG))


def test_the_loop_is_mapped_better_than_odometry(mapped):
    """Odometry ends up ~0.5 m and 8 deg off after the loop; the best particle's trajectory stays within
    12 cm of the truth all the way (the corridors are long and bare: little pins a pose along them) and ends
    within 3 cm, back where it started, and the map's walls lie on the world's."""
    slam, truth, odom = mapped
    stamps, _ = slam.best_trajectory()
    idx = np.round(stamps / 0.1).astype(int)
    odo_world = np.array(pose.compose(truth[0], odom))
    odo_err = np.hypot(*(odo_world[-1, :2] - truth[-1, :2]))
    est = in_world(slam, truth)
    err = np.hypot(*(est[:, :2] - truth[idx, :2]).T)
    assert odo_err > 0.4
    assert err.max() < 0.12, f"worst {err.max():.3f} m at update {err.argmax()}"
    assert err[-1] < 0.03 and np.sqrt(np.mean(err**2)) < 0.06
    assert abs(angles.diff(est[-1, 2], truth[idx[-1], 2])) < math.radians(1.0)
    data, origin, resolution = slam.build_map()
    occupied = np.argwhere(data == 100)
    xy = np.array(pose.compose(truth[0], np.column_stack([origin[0] + (occupied[:, 1] + 0.5) * resolution,
                                                           origin[1] + (occupied[:, 0] + 0.5) * resolution,
                                                           np.zeros(len(occupied))])))[:, :2]
    wall_distance = np.array([min(_to_segment(p, s) for s in WORLD) for p in xy])
    assert len(xy) > 500 and np.mean(wall_distance < 0.0751) > 0.97, np.mean(wall_distance < 0.0751)


def _to_segment(p, seg):
    a, b = seg[:2], seg[2:]
    t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


def test_the_published_map_is_the_best_particles_and_carries_over(mapped):
    slam, _, _ = mapped
    assert slam.best == int(np.argmax(slam.weight_sums))
    data, origin, _ = slam.build_map()
    slam._counts = None  # rebuild from scratch: the same counts
    again, origin_again, _ = slam.build_map()
    np.testing.assert_array_equal(data, again)
    assert origin == origin_again
    assert set(np.unique(data)) == {-1, 0, 100}
    # the map covers at least the initial box (xmin..xmax) and everything seen
    assert origin[0] <= -1.0 and origin[1] <= -1.0
    assert data.shape[1] * 0.05 > 7.5 and data.shape[0] * 0.05 > 7.5


def test_resampling_follows_the_effective_sample_size():
    """Resampling only when N_eff < resampleThreshold N: never at threshold 0, at every update where the
    weights differ at all at threshold 1.01; the copies' weights restart at zero."""
    short = [(4.0, 0.75), (7.25, 0.75)]
    never, _, _ = run(SlamConfig(**{**CONFIG, "resampleThreshold": 0.0}), waypoints=short)
    assert never.resamplings == 0 and never.neff < CONFIG["particles"]
    always, _, _ = run(SlamConfig(**{**CONFIG, "resampleThreshold": 1.01}), waypoints=short)
    assert always.resamplings == always.updates - 1  # every update but the first (no matching there)
    np.testing.assert_array_equal(always.weights, 0.0)


def test_an_upright_laser_maps_the_same_world_the_same_way():
    """The same drive with the laser upright and upside down (its readings in the other order): the same
    trajectory and the same map. The inversion lives in the laser's tf pose, nowhere else."""
    upright, angle_min, _ = laser_scenes.scan(WORLD, (3.0, 0.75, 0.3), laser=laser_scenes.UPRIGHT)
    inverted, _, _ = laser_scenes.scan(WORLD, (3.0, 0.75, 0.3), laser=laser_scenes.UPSIDE_DOWN)
    assert angle_min == pytest.approx(-math.pi / 2)
    np.testing.assert_allclose(inverted, upright[::-1], atol=1e-5)  # what the device reports, as the sim's
    config = SlamConfig(**{**CONFIG, "particles": 3})
    short = [(5.0, 0.75), (7.25, 0.75), (7.25, 3.0)]
    down, truth, _ = run(config, laser_scenes.UPSIDE_DOWN, waypoints=short)
    up, _, _ = run(config, laser_scenes.UPRIGHT, waypoints=short)
    np.testing.assert_allclose(in_world(down, truth), in_world(up, truth), atol=2e-3)
    map_down, map_up = down.build_map()[0], up.build_map()[0]
    assert map_down.shape == map_up.shape
    assert np.mean(map_down == map_up) > 0.995


def test_bad_readings_are_no_readings():
    """Every scan with NaN, -inf, +inf, zeros and readings below range_min sprinkled in, and every tenth scan
    nothing but NaN: mapping goes on and the map has no cell at the laser or at infinity."""
    def spoil(k, ranges):
        if k % 10 == 5:
            return np.full_like(ranges, np.nan)
        r = ranges.copy()
        r[k % 7::7] = [np.nan, -np.inf, np.inf, 0.0, 0.01][k % 5]
        return r

    slam, truth, _ = run(SlamConfig(**{**CONFIG, "particles": 3}), waypoints=[(5.0, 0.75), (7.25, 0.75)],
                         readings=spoil)
    est = in_world(slam, truth)
    stamps, _ = slam.best_trajectory()
    idx = np.round(stamps / 0.1).astype(int)
    assert np.hypot(*(est[:, :2] - truth[idx, :2]).T).max() < 0.05
    data, origin, _ = slam.build_map()
    assert np.isfinite(origin).all() and data.shape[0] * 0.05 < 20 and data.shape[1] * 0.05 < 20


def test_config_from_params_names_a_bad_parameter():
    with pytest.raises(ValueError, match="~particles"):
        config_from_params({"particles": 0}.get)
    with pytest.raises(ValueError, match="xmin"):
        config_from_params({"xmin": 5.0, "xmax": 1.0}.get)
    with pytest.raises(ValueError, match="~sigma"):
        config_from_params({"sigma": float("nan")}.get)
    assert config_from_params({}.get) == SlamConfig()
