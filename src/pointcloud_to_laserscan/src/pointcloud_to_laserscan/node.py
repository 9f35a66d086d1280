"""pointcloud_to_laserscan_node: Kinect depth to a fake laser scan (/kinect_scan, seed 3.7).

ROS Parameters (names of ROS's pointcloud_to_laserscan):
    ~input (str, "cloud"): "cloud" subscribes to cloud_in (PointCloud2), "depth" to
        image + camera_info (depth image 32FC1 [m] or 16UC1 [mm], optical frame).
    ~target_frame (str, "camera_depth_frame"; ~output_frame_id is accepted as the old
        TurtleBot name): frame of the scan; bearings are taken in its x-y plane.
    ~height_frame (str, "base_footprint"): frame whose z is the height used by
        min_height/max_height (the floor on the robot); "" uses target_frame as ROS's
        pointcloud_to_laserscan does.
    ~min_height (float, 0.0, m), ~max_height (float, 1.0, m): band of heights kept.
    ~angle_min (float, -pi/2, rad), ~angle_max (float, pi/2, rad),
    ~angle_increment (float, pi/360, rad): the scan's beams.
    ~scan_time (float, 1/30, s): copied into the scan.
    ~range_min (float, 0.45, m), ~range_max (float, 4.0, m): ranges kept.
    ~use_inf (bool, true): beams without a point read +inf, else range_max + inf_epsilon.
    ~inf_epsilon (float, 1.0, m): see use_inf.

Subscribers:
    cloud_in (sensor_msgs/PointCloud2, float32 x y z fields) when ~input is "cloud".
    image (sensor_msgs/Image) and camera_info (sensor_msgs/CameraInfo) when ~input is "depth".

Publishers:
    scan (sensor_msgs/LaserScan): the fake laser scan, stamped like its input. Inputs
        that cannot be converted (unknown frame, bad encoding, truncated data) give no
        scan and a throttled warning.
"""


import numpy as np
import rospy
import tf2_ros
from sensor_msgs.msg import CameraInfo, Image, LaserScan, PointCloud2, PointField
from std_msgs.msg import Header
from tf.transformations import quaternion_matrix

from pointcloud_to_laserscan.projection import DepthProjector, ScanParams, depth_to_metres, points_to_ranges

LOG = "pointcloud_to_laserscan: "
IMAGE_DTYPES = {"32FC1": np.float32, "16UC1": np.uint16, "mono16": np.uint16}


def matrix(transform):
    """4x4 homogeneous matrix of a geometry_msgs/Transform."""
    q, t = transform.rotation, transform.translation
    m = quaternion_matrix([q.x, q.y, q.z, q.w])
    m[:3, 3] = (t.x, t.y, t.z)
    return m


def image_to_array(msg):
    """(height, width) array of a depth Image, honouring step and endianness."""
    dtype = IMAGE_DTYPES.get(msg.encoding)
    if dtype is None:
        raise ValueError(f"unsupported depth encoding {msg.encoding!r} (need 32FC1 or 16UC1)")
    dtype = np.dtype(dtype).newbyteorder(">" if msg.is_bigendian else "<")
    row = msg.width * dtype.itemsize
    if msg.step < row or len(msg.data) < msg.step * msg.height:
        raise ValueError(f"image data too short: {len(msg.data)} bytes for {msg.height} rows of step {msg.step}")
    rows = np.frombuffer(msg.data, dtype=np.uint8, count=msg.step * msg.height).reshape(msg.height, msg.step)
    return rows[:, :row].copy().view(dtype).reshape(msg.height, msg.width)


def cloud_to_points(msg):
    """(N, 3) float32 x y z of a PointCloud2 (any point_step/row_step, either endianness)."""
    fields = {f.name: f for f in msg.fields}
    for name in "xyz":
        f = fields.get(name)
        if f is None or f.datatype != PointField.FLOAT32:
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


def read_params():
    defaults = ScanParams()
    values = {name: float(rospy.get_param(f"~{name}", getattr(defaults, name)))
              for name in defaults.__dataclass_fields__ if name != "use_inf"}
    values["use_inf"] = bool(rospy.get_param("~use_inf", defaults.use_inf))
    params = ScanParams(**values)
    problems = params.problems()
    if problems:
        raise ValueError("; ".join(problems))
    return params


class PointCloudToLaserScanNode:
    def __init__(self):
        self.params = read_params()
        self.input = str(rospy.get_param("~input", "cloud"))
        if self.input not in ("cloud", "depth"):
            raise ValueError(f"~input must be 'cloud' or 'depth', got {self.input!r}")
        default_target = rospy.get_param("~output_frame_id", "camera_depth_frame")
        self.target_frame = str(rospy.get_param("~target_frame", default_target)).lstrip("/")
        if not self.target_frame:
            raise ValueError("~target_frame must name a frame")
        self.height_frame = str(rospy.get_param("~height_frame", "base_footprint")).lstrip("/") or self.target_frame
        self.projector = DepthProjector(self.params)
        self.camera_info = None
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.pub = rospy.Publisher("scan", LaserScan, queue_size=2)
        if self.input == "cloud":
            self.subs = [rospy.Subscriber("cloud_in", PointCloud2, self.on_cloud, queue_size=1, buff_size=2 ** 24)]
        else:
            self.subs = [rospy.Subscriber("camera_info", CameraInfo, self.on_camera_info, queue_size=1),
                         rospy.Subscriber("image", Image, self.on_image, queue_size=1, buff_size=2 ** 24)]

    def transforms(self, source_frame):
        source_frame = source_frame.lstrip("/")  # tf2 refuses the tf1-style leading "/"
        if not source_frame:
            raise ValueError("input has no frame_id")
        lookup = self.tf_buffer.lookup_transform
        t_target = matrix(lookup(self.target_frame, source_frame, rospy.Time(0)).transform)
        t_height = t_target if self.height_frame == self.target_frame else \
            matrix(lookup(self.height_frame, source_frame, rospy.Time(0)).transform)
        return t_target, t_height

    def publish(self, header, ranges):
        p = self.params
        scan = LaserScan(header=Header(stamp=header.stamp, frame_id=self.target_frame),
                         angle_min=p.angle_min, angle_max=p.angle_max, angle_increment=p.angle_increment,
                         time_increment=0.0, scan_time=p.scan_time, range_min=p.range_min, range_max=p.range_max)
        scan.ranges = ranges.tolist()
        self.pub.publish(scan)

    def guarded(self, convert, msg):
        try:
            self.publish(msg.header, convert(msg))
        except (ValueError, TypeError, tf2_ros.TransformException) as exc:
            rospy.logwarn_throttle(5.0, LOG + f"no scan from a {type(msg).__name__}: {type(exc).__name__}: {exc}")

    def on_cloud(self, msg):
        self.guarded(self.cloud_ranges, msg)

    def cloud_ranges(self, msg):
        t_target, t_height = self.transforms(msg.header.frame_id)
        return points_to_ranges(cloud_to_points(msg), t_target, t_height, self.params)

    def on_camera_info(self, msg):
        self.camera_info = msg

    def on_image(self, msg):
        self.guarded(self.image_ranges, msg)

    def image_ranges(self, msg):
        info = self.camera_info
        if info is None:
            raise ValueError("no camera_info received yet")
        if (info.width, info.height) != (msg.width, msg.height):
            raise ValueError(f"camera_info is {info.width}x{info.height}, image {msg.width}x{msg.height}")
        t_target, t_height = self.transforms(msg.header.frame_id)
        z = depth_to_metres(image_to_array(msg), msg.encoding)
        return self.projector.ranges(z, info.K, t_target, t_height)


def main():
    rospy.init_node("pointcloud_to_laserscan")
    try:
        PointCloudToLaserScanNode()
    except (ValueError, TypeError) as exc:
        rospy.logfatal(LOG + "bad parameters: %s", exc)
        raise SystemExit(1) from exc
    rospy.spin()


