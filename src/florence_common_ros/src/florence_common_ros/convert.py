"""Message conversions: geometry_msgs poses and transforms <-> (x, y, yaw) and 4x4 matrices,
sensor_msgs/Image <-> numpy arrays (through Debian's cv_bridge).

The maths is florence_common.pose's; this module only unpacks and packs messages.
"""

import copy

import numpy as np
from geometry_msgs.msg import Pose, PoseStamped, Quaternion, Transform, TransformStamped

from florence_common import pose as pose2d
from florence_common.images import depth_metres

# --- orientations -------------------------------------------------------------------------------


def quaternion_msg(yaw):
    """geometry_msgs/Quaternion of a rotation by ``yaw`` [rad] about z."""
    return Quaternion(*pose2d.yaw_to_quaternion(float(yaw)))


def yaw_of(q):
    """Yaw [rad] of a geometry_msgs/Quaternion (ValueError for a zero quaternion)."""
    return pose2d.quaternion_to_yaw((q.x, q.y, q.z, q.w))


def quaternion_tuple(q):
    return (q.x, q.y, q.z, q.w)


# --- poses and transforms ----------------------------------------------------------------------------


def _pose_parts(msg):
    """(position-like, orientation) of a Pose, PoseStamped, PoseWithCovariance(Stamped),
    Odometry, Transform or TransformStamped."""
    for attr in ("pose", "transform"):  # unwrap stamped / covariance / odometry layers
        while hasattr(msg, attr):
            msg = getattr(msg, attr)
    if isinstance(msg, Transform):
        return msg.translation, msg.rotation
    return msg.position, msg.orientation


def to_xyyaw(msg):
    """(x [m], y [m], yaw [rad]) of any pose or transform message (see _pose_parts)."""
    p, q = _pose_parts(msg)
    return float(p.x), float(p.y), yaw_of(q)


def pose_msg(x, y, yaw):
    """geometry_msgs/Pose at (x, y, 0) with heading ``yaw``."""
    msg = Pose()
    msg.position.x, msg.position.y = float(x), float(y)
    msg.orientation = quaternion_msg(yaw)
    return msg


def pose_stamped(x, y, yaw, frame_id, stamp=None):
    msg = PoseStamped()
    msg.header.frame_id = frame_id
    if stamp is not None:
        msg.header.stamp = stamp
    msg.pose = pose_msg(x, y, yaw)
    return msg


def transform_stamped(stamp, parent, child, x, y, yaw, z=0.0):
    """geometry_msgs/TransformStamped of a planar pose of ``child`` in ``parent``."""
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = float(x), float(y), float(z)
    t.transform.rotation = quaternion_msg(yaw)
    return t


def to_matrix(msg):
    """4x4 homogeneous matrix of any pose or transform message."""
    p, q = _pose_parts(msg)
    return pose2d.transform_matrix((p.x, p.y, p.z), quaternion_tuple(q))


def matrix_to_transform_msg(m):
    """geometry_msgs/Transform of a 4x4 homogeneous matrix."""
    (x, y, z), q = pose2d.matrix_to_transform(m)
    t = Transform()
    t.translation.x, t.translation.y, t.translation.z = x, y, z
    t.rotation = Quaternion(*q)
    return t


# --- people ------------------------------------------------------------------------------------------
def tracked_users(msg):
    """(persistent ids [N] int, positions [N, 2], velocities [N, 2]) [m, m/s] of a
    user_tracker_ni/TrackedUsers, in its ``frame_id`` (read by field: the class is not imported
    here). ValueError when it carries no positions for its users (the seed's three fields only) or
    lists of other lengths; velocities that are missing are zeros."""
    ids = np.asarray(msg.user_ids, dtype=int)
    positions = getattr(msg, "positions", None)
    if positions is None or len(positions) != len(ids):
        raise ValueError(f"{len(ids)} users with {0 if positions is None else len(positions)} positions")
    xy = np.array([(p.x, p.y) for p in positions], dtype=float).reshape(-1, 2)
    velocities = getattr(msg, "velocities", None) or []
    if len(velocities) == len(ids):
        vxy = np.array([(v.x, v.y) for v in velocities], dtype=float).reshape(-1, 2)
    elif not velocities:
        vxy = np.zeros_like(xy)
    else:
        raise ValueError(f"{len(ids)} users with {len(velocities)} velocities")
    return ids, xy, vxy


# --- images ----------------------------------------------------------------------------------------------
_bridge = None


def _cv_bridge():
    global _bridge  # noqa: PLW0603 - one CvBridge per process, made on first use
    if _bridge is None:
        from cv_bridge import CvBridge

        _bridge = CvBridge()
    return _bridge


def image_to_array(msg, encoding="passthrough"):
    """numpy array of a sensor_msgs/Image (cv_bridge: ``encoding`` as its desired_encoding; row
    padding and either byte order are honoured). Raises ValueError, naming the image, for an
    image that does not decode: an unknown encoding, data shorter than height x step, or a step
    that is no whole number of pixels (cv_bridge would misread the rows)."""
    from cv_bridge import CvBridgeError

    what = f"{msg.width}x{msg.height} {msg.encoding!r} image"
    bridge = _cv_bridge()
    try:
        dtype, channels = bridge.encoding_to_dtype_with_channels(msg.encoding)
    except (CvBridgeError, TypeError, ValueError, KeyError) as exc:
        raise ValueError(f"{what}: unsupported encoding ({exc})") from exc
    pixel = np.dtype(dtype).itemsize * channels
    if msg.step < msg.width * pixel or msg.step % np.dtype(dtype).itemsize:
        raise ValueError(f"{what}: step {msg.step} bytes does not hold {msg.width} pixels of {pixel} bytes")
    if len(msg.data) < msg.step * msg.height:
        raise ValueError(f"{what}: data too short ({len(msg.data)} bytes for {msg.height} rows of {msg.step})")
    if msg.step != msg.width * pixel:
        # Debian's cv_bridge (1.16) reads rows as width x pixel bytes and ignores step: repack
        # padded rows first, or every row after the first would be shifted
        rows = np.frombuffer(msg.data, np.uint8, count=msg.step * msg.height).reshape(msg.height, msg.step)
        msg = copy.copy(msg)
        msg.data, msg.step = rows[:, :msg.width * pixel].tobytes(), msg.width * pixel
    try:
        return bridge.imgmsg_to_cv2(msg, desired_encoding=encoding)
    except (CvBridgeError, TypeError, ValueError) as exc:
        raise ValueError(f"{what}: {exc}") from exc


def depth_image_metres(msg):
    """float32 metres (NaN for no return) of a 32FC1 [m] or 16UC1 [mm] depth image; ValueError for
    another encoding or data that does not decode."""
    return depth_metres(image_to_array(msg), msg.encoding)


def array_to_image(array, encoding, header=None):
    """sensor_msgs/Image of a numpy array (cv_bridge), with ``header`` when given."""
    msg = _cv_bridge().cv2_to_imgmsg(np.ascontiguousarray(array), encoding=encoding)
    if header is not None:
        msg.header = header
    return msg


# --- point clouds -------------------------------------------------------------------------------
_FLOAT32 = 7  # sensor_msgs/PointField.FLOAT32


def cloud_to_points(msg):
    """(N, 3) float32 x y z of a sensor_msgs/PointCloud2 (any point_step/row_step, either endianness;
    NaN points kept); ValueError naming the problem for a cloud without float32 x, y, z or with
    too little data."""
    fields = {f.name: f for f in msg.fields}
    for name in "xyz":
        f = fields.get(name)
        if f is None or f.datatype != _FLOAT32:
            raise ValueError(f"cloud field {name!r} missing or not FLOAT32")
    order = ">" if msg.is_bigendian else "<"
    dtype = np.dtype({"names": list("xyz"), "formats": [order + "f4"] * 3,
                      "offsets": [fields[n].offset for n in "xyz"], "itemsize": msg.point_step})
    if msg.point_step < 12 or msg.row_step < msg.width * msg.point_step or \
            len(msg.data) < msg.row_step * msg.height:
        raise ValueError(f"cloud data too short or steps inconsistent ({len(msg.data)} bytes, "
                         f"{msg.height}x{msg.width}, point_step {msg.point_step}, row_step {msg.row_step})")
    rows = np.frombuffer(msg.data, dtype=np.uint8, count=msg.row_step * msg.height).reshape(msg.height, msg.row_step)
    pts = rows[:, :msg.width * msg.point_step].copy().view(dtype).reshape(-1)
    return np.stack([pts["x"], pts["y"], pts["z"]], axis=1).astype(np.float32)
