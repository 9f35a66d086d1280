"""Message conversions: poses, transforms, matrices and images."""

import math

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped, Quaternion, TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs import point_cloud2
from sensor_msgs.msg import PointField
from std_msgs.msg import Header

from florence_common_ros import convert

pytestmark = pytest.mark.unit


def test_quaternion_msg_and_yaw_of():
    q = convert.quaternion_msg(math.pi / 2)
    assert (q.x, q.y) == (0.0, 0.0)
    assert (q.z, q.w) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5)))
    assert convert.yaw_of(q) == pytest.approx(math.pi / 2)
    with pytest.raises(ValueError):
        convert.yaw_of(Quaternion(0, 0, 0, 0))


def test_to_xyyaw_reads_every_pose_layer():
    odom = Odometry()
    odom.pose.pose = convert.pose_msg(1.0, 2.0, 0.5)
    assert convert.to_xyyaw(odom) == pytest.approx((1.0, 2.0, 0.5))
    pwc = PoseWithCovarianceStamped()
    pwc.pose.pose = convert.pose_msg(-1.0, 0.5, -3.0)
    assert convert.to_xyyaw(pwc) == pytest.approx((-1.0, 0.5, -3.0))
    ps = convert.pose_stamped(3.0, 4.0, 1.0, "map")
    assert ps.header.frame_id == "map" and convert.to_xyyaw(ps) == pytest.approx((3.0, 4.0, 1.0))
    t = convert.transform_stamped(None, "odom", "base_footprint", 0.2, -0.1, 0.3)
    assert isinstance(t, TransformStamped) and (t.header.frame_id, t.child_frame_id) == ("odom", "base_footprint")
    assert convert.to_xyyaw(t) == pytest.approx((0.2, -0.1, 0.3))


def test_matrix_round_trip():
    t = convert.transform_stamped(None, "a", "b", 1.0, 2.0, 0.4, z=0.5)
    m = convert.to_matrix(t)
    assert m[:3, 3] == pytest.approx([1.0, 2.0, 0.5])
    back = convert.matrix_to_transform_msg(m)
    assert convert.to_xyyaw(back) == pytest.approx((1.0, 2.0, 0.4))


@pytest.mark.parametrize(("dtype", "encoding"), [(np.float32, "32FC1"), (np.uint16, "16UC1"), (np.uint8, "rgb8")])
def test_images_round_trip_through_cv_bridge(dtype, encoding):
    shape = (4, 5, 3) if encoding == "rgb8" else (4, 5)
    array = (np.arange(np.prod(shape)) % 200).reshape(shape).astype(dtype)
    header = Header(frame_id="camera_depth_optical_frame")
    msg = convert.array_to_image(array, encoding, header)
    assert (msg.width, msg.height, msg.encoding, msg.header.frame_id) == (5, 4, encoding, header.frame_id)
    assert np.array_equal(convert.image_to_array(msg), array)


def test_an_image_that_does_not_decode_is_a_value_error():
    msg = convert.array_to_image(np.zeros((4, 5), np.float32), "32FC1")
    msg.data = msg.data[:10]  # truncated
    with pytest.raises(ValueError, match="32FC1"):
        convert.image_to_array(msg)


def test_padded_rows_are_read_right():
    """Debian's cv_bridge ignores step; the wrapper repacks padded rows first."""
    array = np.arange(12, dtype=np.uint16).reshape(3, 4)
    msg = convert.array_to_image(array, "16UC1")
    rows = np.frombuffer(msg.data, np.uint8).reshape(3, 8)
    msg.data = np.hstack([rows, np.full((3, 8), 0xAB, np.uint8)]).tobytes()
    msg.step = 16
    assert np.array_equal(convert.image_to_array(msg), array)


# --- point clouds (from pointcloud_to_laserscan, which shares this decoder with move_base) -----------
def test_cloud_decoding_with_extra_fields():
    fields = [PointField("x", 0, PointField.FLOAT32, 1), PointField("y", 4, PointField.FLOAT32, 1),
              PointField("z", 8, PointField.FLOAT32, 1), PointField("rgb", 16, PointField.FLOAT32, 1)]
    pts = [(1.0, 2.0, 3.0, 0.0), (4.0, 5.0, 6.0, 0.0)]
    msg = point_cloud2.create_cloud(Header(frame_id="f"), fields, pts)
    assert msg.point_step == 20
    assert convert.cloud_to_points(msg) == pytest.approx(np.array([[1, 2, 3], [4, 5, 6]], np.float32))


def test_bad_clouds_are_clear_errors():
    msg = point_cloud2.create_cloud_xyz32(Header(frame_id="f"), [(1.0, 2.0, 3.0)] * 4)
    msg.data = msg.data[:-1]
    with pytest.raises(ValueError, match="too short"):
        convert.cloud_to_points(msg)
    msg = point_cloud2.create_cloud(Header(frame_id="f"), [PointField("x", 0, PointField.FLOAT32, 1)], [(1.0,)])
    with pytest.raises(ValueError, match="'y'"):
        convert.cloud_to_points(msg)
