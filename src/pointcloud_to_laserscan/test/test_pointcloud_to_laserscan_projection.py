"""Depth to scan on the ROS-free core: geometry, height band, range limits, no-return
values, both depth encodings, and the fast path agreeing with the general one."""

import math

import numpy as np
import pytest
from pointcloud_to_laserscan.projection import (
    DepthProjector,
    ScanParams,
    points_to_ranges,
)

pytestmark = pytest.mark.unit

K = [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0]  # Kinect depth intrinsics
W, H = 640, 480
CAM_HEIGHT = 0.45  # [m] optical centre above the floor
# optical frame (z forward, x right, y down) -> camera_depth_frame (x forward, y left, z up)
OPT = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1.0]])
FLOOR = OPT.copy()
FLOOR[2, 3] = CAM_HEIGHT  # optical frame -> a floor frame under the camera
PARAMS = ScanParams(min_height=0.05, max_height=1.0)


def beam_angle(i, p=PARAMS):
    return p.angle_min + (i + 0.5) * p.angle_increment


def wall(distance):
    """Depth image of a wall facing the camera at ``distance`` [m] (32FC1)."""
    return np.full((H, W), distance, np.float32)


def test_wall_ahead_reads_distance_over_cos_bearing():
    r = DepthProjector(PARAMS).ranges(wall(2.0), K, OPT, FLOOR)
    assert r.size == PARAMS.size == 360
    centre = PARAMS.size // 2
    assert r[centre] == pytest.approx(2.0, abs=0.01)
    for i in (centre - 40, centre + 40):  # +-20 degrees, inside the 58 degree field of view
        assert r[i] == pytest.approx(2.0 / math.cos(beam_angle(i)), rel=0.01)
    assert np.isinf(r[0]) and np.isinf(r[-1])  # outside the field of view


def test_left_is_positive_bearing():
    z = np.full((H, W), np.nan, np.float32)
    z[:, :100] = 1.5  # left edge of the image (x negative in the optical frame) -> robot's left
    r = DepthProjector(PARAMS).ranges(z, K, OPT, FLOOR)
    seen = np.flatnonzero(np.isfinite(r))
    assert seen.size and all(beam_angle(i) > 0 for i in seen)


def floor_and_table_image(table_height):
    """Depth of the floor plane, with a table top at ``table_height`` covering the rows above it."""
    v = np.arange(H, dtype=np.float64)[:, None]
    ray_down = (v - K[5]) / K[4]  # optical y per metre of depth (down is positive)
    with np.errstate(divide="ignore"):
        floor = np.where(ray_down > 0, CAM_HEIGHT / ray_down, np.nan)
        table = np.where(ray_down > 0, (CAM_HEIGHT - table_height) / ray_down, np.nan)
    z = np.where(table < 1.5, table, floor) if table_height < CAM_HEIGHT else floor
    return np.broadcast_to(z, (H, W)).astype(np.float32)


def test_floor_is_not_an_obstacle():
    r = DepthProjector(PARAMS).ranges(floor_and_table_image(-1.0), K, OPT, FLOOR)
    assert np.all(np.isinf(r))


@pytest.mark.parametrize("max_height, seen", [(1.0, True), (0.1, False)])
def test_height_band_keeps_or_drops_a_low_obstacle(max_height, seen):
    params = ScanParams(min_height=0.05, max_height=max_height)
    r = DepthProjector(params).ranges(floor_and_table_image(0.3), K, OPT, FLOOR)
    assert bool(np.isfinite(r).any()) is seen


@pytest.mark.parametrize("distance, seen", [(0.4, False), (0.5, True), (3.9, True), (4.5, False)])
def test_range_limits(distance, seen):
    r = DepthProjector(PARAMS).ranges(wall(distance), K, OPT, FLOOR)
    assert bool(np.isfinite(r[PARAMS.size // 2])) is seen


def test_no_return_value_without_use_inf():
    params = ScanParams(min_height=0.05, max_height=1.0, use_inf=False, inf_epsilon=1.0)
    r = DepthProjector(params).ranges(wall(np.nan), K, OPT, FLOOR)
    assert r == pytest.approx(np.full(params.size, 5.0))


def back_project(z):
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    return np.stack([(u - K[2]) / K[0] * z, (v - K[5]) / K[4] * z, z], axis=-1).reshape(-1, 3)


@pytest.mark.parametrize("offset", [0.0, 0.1])
def test_depth_path_matches_point_cloud_path(offset):
    rng = np.random.default_rng(1)
    z = rng.uniform(0.3, 5.0, (H, W)).astype(np.float32)
    z[rng.random((H, W)) < 0.1] = np.nan
    t_target = OPT.copy()
    t_target[0, 3] = offset  # 0: fast path; 0.1 m: general path
    from_depth = DepthProjector(PARAMS).ranges(z, K, t_target, FLOOR)
    from_cloud = points_to_ranges(back_project(z), t_target, FLOOR, PARAMS)
    finite = np.isfinite(from_cloud)
    assert np.array_equal(finite, np.isfinite(from_depth))
    assert from_depth[finite] == pytest.approx(from_cloud[finite], rel=1e-5)


def test_point_cloud_bearings_and_nearest_point():
    pts = np.array([[2.0, 0.0, 0.3], [1.0, 0.001, 0.3], [1.0, 1.0, 0.3], [1.0, -1.0, 2.0],
                    [np.nan, 0, 0], [0.1, 0.0, 0.3]])
    r = points_to_ranges(pts, np.eye(4), np.eye(4), PARAMS)
    assert r[180] == pytest.approx(1.0, abs=1e-6)  # nearest of the two points ahead
    assert r[270] == pytest.approx(math.sqrt(2), abs=1e-6)  # 45 degrees left
    assert np.count_nonzero(np.isfinite(r)) == 2  # too high, NaN and too near are skipped


def test_camera_info_without_focal_length_is_an_error():
    with pytest.raises(ValueError, match="focal"):
        DepthProjector(PARAMS).ranges(wall(1.0), [0.0] * 9, OPT, FLOOR)


@pytest.mark.parametrize(
    "change, message",
    [({"angle_increment": 0.0}, "angle_increment"), ({"angle_min": 1.0, "angle_max": 0.0}, "angle_min"),
     ({"min_height": 1.0, "max_height": 0.5}, "min_height"), ({"range_min": 5.0}, "range_min"),
     ({"range_max": math.nan}, "range_max")],
)
def test_nonsense_parameters_are_named(change, message):
    assert any(message in p for p in ScanParams(**change).problems())
    assert ScanParams().problems() == []
