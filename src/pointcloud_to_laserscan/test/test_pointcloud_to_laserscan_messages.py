"""Message decoding of the node: depth images through florence_common_ros.convert (cv_bridge;
both encodings, row padding, endianness) and point clouds (point_step padding), and the clear
errors on malformed input."""

import numpy as np
import pytest
from pointcloud_to_laserscan.node import cloud_to_points
from sensor_msgs import point_cloud2
from sensor_msgs.msg import Image, PointField
from std_msgs.msg import Header

from florence_common_ros.convert import depth_image_metres

pytestmark = pytest.mark.unit


def image(array, encoding, pad=0, bigendian=False):
    arr = array.astype(array.dtype.newbyteorder(">" if bigendian else "<"))
    rows = [arr[i].tobytes() + b"\0" * pad for i in range(arr.shape[0])]
    return Image(height=arr.shape[0], width=arr.shape[1], encoding=encoding, is_bigendian=bigendian,
                 step=arr.shape[1] * arr.itemsize + pad, data=b"".join(rows))


@pytest.mark.parametrize("encoding, dtype", [("32FC1", np.float32), ("16UC1", np.uint16)])
@pytest.mark.parametrize("pad, bigendian", [(0, False), (8, False), (0, True)])
def test_image_decoding(encoding, dtype, pad, bigendian):
    arr = (np.arange(1, 13).reshape(3, 4) * 100).astype(dtype)
    out = depth_image_metres(image(arr, encoding, pad, bigendian))
    scale = 1.0 if encoding == "32FC1" else 0.001  # 16UC1 is millimetres
    assert out.shape == (3, 4) and np.allclose(out, arr.astype(np.float64) * scale)


@pytest.mark.parametrize(
    "msg, message",
    [
        (Image(height=2, width=2, encoding="rgb8", step=6, data=b"\0" * 12), "encoding"),
        (Image(height=2, width=2, encoding="32FC1", step=8, data=b"\0" * 12), "too short"),
        (Image(height=2, width=2, encoding="16UC1", step=2, data=b"\0" * 8), "does not hold"),
        (Image(height=2, width=2, encoding="32FC1", step=10, data=b"\0" * 20), "does not hold"),
    ],
    ids=["encoding", "truncated", "step-too-small", "step-not-whole-pixels"],
)
def test_bad_images_are_clear_errors(msg, message):
    with pytest.raises(ValueError, match=message):
        depth_image_metres(msg)


def test_cloud_decoding_with_extra_fields():
    fields = [PointField("x", 0, PointField.FLOAT32, 1), PointField("y", 4, PointField.FLOAT32, 1),
              PointField("z", 8, PointField.FLOAT32, 1), PointField("rgb", 16, PointField.FLOAT32, 1)]
    pts = [(1.0, 2.0, 3.0, 0.0), (4.0, 5.0, 6.0, 0.0)]
    msg = point_cloud2.create_cloud(Header(frame_id="f"), fields, pts)
    assert msg.point_step == 20
    assert cloud_to_points(msg) == pytest.approx(np.array([[1, 2, 3], [4, 5, 6]], np.float32))


def test_bad_clouds_are_clear_errors():
    msg = point_cloud2.create_cloud_xyz32(Header(frame_id="f"), [(1.0, 2.0, 3.0)] * 4)
    msg.data = msg.data[:-1]
    with pytest.raises(ValueError, match="too short"):
        cloud_to_points(msg)
    msg = point_cloud2.create_cloud(Header(frame_id="f"), [PointField("x", 0, PointField.FLOAT32, 1)], [(1.0,)])
    with pytest.raises(ValueError, match="'y'"):
        cloud_to_points(msg)
