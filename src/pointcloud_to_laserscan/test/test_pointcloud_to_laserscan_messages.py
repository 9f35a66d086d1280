"""Message decoding of the node: depth images through florence_common_ros.convert (cv_bridge;
both encodings, row padding, endianness) and the clear errors on malformed input (point clouds:
florence_common_ros.convert.cloud_to_points, tested there)."""

import numpy as np
import pytest
from sensor_msgs.msg import Image

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
