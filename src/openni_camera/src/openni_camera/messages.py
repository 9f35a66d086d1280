"""The camera node's messages, built and serialised with as few copies of the pixels as possible.

At 640x480 / 30 Hz the node publishes 4.9 MB clouds, 1.2 MB depth and 0.9 MB colour images a
frame. genpy's generated ``serialize`` writes a ``uint8[]`` field through
``struct.pack('<I%ss' % n, n, data)``: a copy of the whole payload before the copy into
rospy's buffer. :class:`PointCloud2Out` and :class:`ImageOut` are the same message types (same
``_type`` and ``_md5sum``: subscribers see plain sensor_msgs) whose ``serialize`` writes the
fields before ``data`` through the generated code and ``data`` itself straight from its buffer.
"""

import io
import struct

from sensor_msgs.msg import CameraInfo, Image, PointCloud2, PointField

from florence_common_ros.convert import array_to_image
from openni_camera.registration import POINT_FIELDS, POINT_STEP

_LENGTH = struct.Struct("<I")


def _serialize_around_data(msg, base, buff, tail_bytes):
    """``base.serialize`` of ``msg`` with its data written from its own buffer: the generated code
    writes everything with an empty data (its length field, then ``tail_bytes`` of later fields)."""
    data = msg.data
    msg.data = b""
    try:
        head = io.BytesIO()
        base.serialize(msg, head)
    finally:
        msg.data = data
    fixed = head.getvalue()
    cut = len(fixed) - 4 - tail_bytes
    buff.write(fixed[:cut])
    buff.write(_LENGTH.pack(len(data)))
    buff.write(data)
    if tail_bytes:
        buff.write(fixed[-tail_bytes:])


class PointCloud2Out(PointCloud2):
    """sensor_msgs/PointCloud2 that serialises ``data`` (bytes-like) without an extra copy."""

    __slots__ = ()

    def serialize(self, buff):
        _serialize_around_data(self, PointCloud2, buff, tail_bytes=1)  # is_dense follows data


class ImageOut(Image):
    """sensor_msgs/Image that serialises ``data`` (bytes-like) without an extra copy."""

    __slots__ = ()

    def serialize(self, buff):
        _serialize_around_data(self, Image, buff, tail_bytes=0)


def image_msg(array, encoding, stamp, frame_id):
    """An ImageOut of a numpy image (cv_bridge makes the fields)."""
    built = array_to_image(array, encoding)
    msg = ImageOut()
    msg.header.stamp, msg.header.frame_id = stamp, frame_id
    msg.height, msg.width, msg.encoding = built.height, built.width, built.encoding
    msg.is_bigendian, msg.step, msg.data = built.is_bigendian, built.step, built.data
    return msg


def cloud_msg(cloud, stamp, frame_id):
    """PointCloud2Out of a (H, W, 4) float32 cloud (Registration.cloud), organised, not dense."""
    h, w = cloud.shape[:2]
    msg = PointCloud2Out()
    msg.header.stamp, msg.header.frame_id = stamp, frame_id
    msg.height, msg.width = h, w
    msg.fields = [PointField(name, offset, PointField.FLOAT32, 1) for name, offset in POINT_FIELDS]
    msg.is_bigendian = False
    msg.point_step, msg.row_step = POINT_STEP, POINT_STEP * w
    msg.is_dense = False
    msg.data = memoryview(cloud).cast("B")  # the array's own bytes: no copy until rospy's buffer
    return msg


def camera_info_msg(info, stamp, frame_id):
    """sensor_msgs/CameraInfo of an openni_camera.camera_info.CameraInfo."""
    msg = CameraInfo()
    msg.header.stamp, msg.header.frame_id = stamp, frame_id
    msg.width, msg.height = info.width, info.height
    msg.distortion_model = info.distortion_model
    msg.D, msg.K, msg.R, msg.P = list(info.D), list(info.K), list(info.R), list(info.P)
    return msg
