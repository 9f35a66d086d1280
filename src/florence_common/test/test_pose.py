"""2-D pose maths and quaternions (REP 103)."""

import math

import numpy as np
import pytest

from florence_common import pose

pytestmark = pytest.mark.unit


def test_compose_places_a_child_frame():
    # a laser 0.1 m ahead of a robot at (1, 2) facing +y is at (1, 2.1)
    assert pose.compose((1.0, 2.0, math.pi / 2), (0.1, 0.0, 0.0)) == pytest.approx((1.0, 2.1, math.pi / 2))


def test_inverse_and_relative():
    p = (1.0, -2.0, 0.7)
    assert pose.compose(p, pose.inverse(p)) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    q = (3.0, 1.0, -2.5)
    assert pose.compose(p, pose.relative(p, q)) == pytest.approx(q)
    # a point ahead and to the left of the robot is at positive x and y in its frame
    assert pose.relative((0.0, 0.0, math.pi / 2), (-1.0, 1.0, 0.0))[:2] == pytest.approx((1.0, 1.0))


def test_vectorised_compose_matches_one_by_one():
    rng = np.random.default_rng(2)
    a, b = rng.uniform(-3, 3, (50, 3)), rng.uniform(-3, 3, (50, 3))
    out = pose.compose(a, b)
    assert out.shape == (50, 3)
    for i in range(50):
        assert out[i] == pytest.approx(pose.compose(tuple(a[i]), tuple(b[i])))
    assert np.all(out[:, 2] >= -math.pi) and np.all(out[:, 2] < math.pi)


def test_transform_points_and_matrices():
    p = (1.0, 2.0, math.pi / 2)
    pts = pose.transform_points(p, [[1.0, 0.0], [0.0, 1.0]])
    assert pts == pytest.approx(np.array([[1.0, 3.0], [0.0, 2.0]]))
    m = pose.to_matrix(p)
    assert pose.from_matrix(m) == pytest.approx(p)
    assert pose.from_matrix(pose.planar_matrix(*p)) == pytest.approx(p)


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.0, math.pi - 1e-9, -math.pi])
def test_yaw_quaternion_round_trip(yaw):
    q = pose.yaw_to_quaternion(yaw)
    assert q[0] == q[1] == 0.0
    assert math.hypot(q[2], q[3]) == pytest.approx(1.0)
    assert math.cos(pose.quaternion_to_yaw(q) - yaw) == pytest.approx(1.0)


def test_quaternion_to_yaw_matches_tf_getyaw_for_tilted_rotations():
    # tf::getYaw: atan2(2 (w z + x y), 1 - 2 (y^2 + z^2)) for a unit quaternion
    rng = np.random.default_rng(3)
    for raw in rng.normal(size=(20, 4)):
        q = raw / np.linalg.norm(raw)
        x, y, z, w = q
        expected = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        assert pose.quaternion_to_yaw(q) == pytest.approx(expected, abs=1e-9)
    yaws = pose.quaternion_to_yaw(pose.yaw_to_quaternion(np.array([0.1, 0.2])))
    assert yaws == pytest.approx([0.1, 0.2])


def test_zero_quaternion_is_refused():
    with pytest.raises(ValueError):
        pose.quaternion_to_yaw((0.0, 0.0, 0.0, 0.0))


def test_transform_matrix_round_trip_and_rpy():
    # the inverted laser: rolled by pi, 6 cm forward
    m = pose.transform_matrix((0.06, 0.0, -0.02), pose.matrix_to_transform(
        np.block([[pose.rpy_to_matrix((math.pi, 0, 0)), np.zeros((3, 1))], [np.zeros((1, 3)), 1]]))[1])
    assert m[:3, :3] @ [0, 0, 1] == pytest.approx([0, 0, -1])
    t, q = pose.matrix_to_transform(m)
    assert t == pytest.approx((0.06, 0.0, -0.02))
    assert abs(pose.quaternion_to_rpy(q)[0]) == pytest.approx(math.pi)


def test_depth_metres_of_both_encodings():
    from florence_common.images import depth_metres

    mm = np.array([[0, 1500], [65535, 250]], np.uint16)
    assert np.allclose(depth_metres(mm, "16UC1"), [[np.nan, 1.5], [65.535, 0.25]], equal_nan=True)
    m = np.array([[np.nan, 1.5], [np.inf, -1.0]], np.float32)
    out = depth_metres(m, "32FC1")
    assert out.dtype == np.float32 and np.isnan(out[0, 0]) and out[0, 1] == 1.5 and np.isnan(out[1]).all()
    with pytest.raises(ValueError, match="8UC1"):
        depth_metres(mm, "8UC1")


def test_beams_in_plane_upright_yawed_and_upside_down():
    """Florence's Hokuyo (base_laser_link: xyz 0.06 0 -0.02, rpy pi 0 0): a beam at +a in the laser frame
    points to -a on the base, and the laser's z axis points down."""
    angles = np.array([-1.5, -0.3, 0.0, 0.5, 2.0])
    xy, bearings, up = pose.beams_in_plane(pose.transform_matrix((0.06, 0.0, -0.02), (1.0, 0.0, 0.0, 0.0)), angles)
    np.testing.assert_allclose(xy, [0.06, 0.0])
    np.testing.assert_allclose(bearings, -angles, atol=1e-12)
    assert up == pytest.approx(-1.0)
    _, upright, up = pose.beams_in_plane(np.eye(4), angles)
    np.testing.assert_allclose(upright, angles, atol=1e-12)
    assert up == pytest.approx(1.0)
    _, yawed, _ = pose.beams_in_plane(pose.planar_matrix(0.0, 0.0, 0.5), angles)
    np.testing.assert_allclose(yawed, angles + 0.5, atol=1e-12)
    tilted = pose.transform_matrix((0, 0, 0), tuple(pose.Rotation.from_euler("y", 0.3).as_quat()))
    assert pose.beams_in_plane(tilted, angles)[2] == pytest.approx(math.cos(0.3))


def test_segment_distances():
    pts = [(0.5, 1.0), (-1.0, 0.0), (3.0, -4.0), (1.0, 0.0)]
    d = pose.segment_distances(pts, (0.0, 0.0), (2.0, 0.0))
    assert d == pytest.approx([1.0, 1.0, math.hypot(1.0, 4.0), 0.0])  # beside, beyond each end, on it
    assert pose.segment_distances([(3.0, 4.0)], (0.0, 0.0), (0.0, 0.0)) == pytest.approx([5.0])  # a point
