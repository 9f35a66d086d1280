"""pointcloud_to_laserscan_node: Kinect depth to a fake laser scan (/kinect_scan, seed 3.7).

ROS Parameters: PARAMS below, the names of ROS's pointcloud_to_laserscan (rendered in the README).

ROS Subscribers:
    cloud_in (sensor_msgs/PointCloud2, float32 x y z fields) when ~input is "cloud".
    image (sensor_msgs/Image) and camera_info (sensor_msgs/CameraInfo) when ~input is "depth".

ROS Publishers:
    scan (sensor_msgs/LaserScan): the fake laser scan, stamped like its input. Inputs
        that cannot be converted (unknown frame, bad encoding, truncated data) give no
        scan and a throttled warning.
    /diagnostics: the input rate, scans published, inputs dropped and the last reason.
"""



import rospy
import tf2_ros
from sensor_msgs.msg import CameraInfo, Image, LaserScan, PointCloud2
from std_msgs.msg import Header

from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.convert import cloud_to_points, depth_image_metres, to_matrix
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from pointcloud_to_laserscan.projection import DepthProjector, ScanParams, points_to_ranges

LOG = "pointcloud_to_laserscan: "
_D = ScanParams()
PARAMS = ParamTable(
    Param("input", str, "cloud", '"cloud" subscribes to cloud_in (PointCloud2), "depth" to image + camera_info '
          "(32FC1 [m] or 16UC1 [mm], optical frame)", choices=("cloud", "depth")),
    Param("target_frame", FRAME, "", "frame of the scan; bearings are taken in its x-y plane (empty: "
          "~output_frame_id)"),
    Param("output_frame_id", FRAME, "camera_depth_frame", "the old TurtleBot name of ~target_frame"),
    Param("height_frame", FRAME, "base_footprint", "frame whose z is the height of min_height/max_height (the "
          "floor on the robot); empty: target_frame, as ROS's pointcloud_to_laserscan"),
    Param("min_height", float, _D.min_height, "lowest point kept", unit="m"),
    Param("max_height", float, _D.max_height, "highest point kept", unit="m"),
    Param("angle_min", float, _D.angle_min, "first beam", unit="rad"),
    Param("angle_max", float, _D.angle_max, "last beam", unit="rad"),
    Param("angle_increment", float, _D.angle_increment, "between beams", unit="rad", gt=0),
    Param("scan_time", float, _D.scan_time, "copied into the scan", unit="s", ge=0),
    Param("range_min", float, _D.range_min, "nearer points are not used", unit="m", ge=0),
    Param("range_max", float, _D.range_max, "farther points are not used", unit="m", gt=0),
    Param("use_inf", bool, _D.use_inf, "beams without a point read +inf (false: range_max + inf_epsilon)"),
    Param("inf_epsilon", float, _D.inf_epsilon, "see use_inf", unit="m", ge=0),
)
SCAN_FIELDS = tuple(ScanParams.__dataclass_fields__)


class PointCloudToLaserScanNode:
    def __init__(self):
        p = read_params(PARAMS)
        self.params = ScanParams(**{name: p[name] for name in SCAN_FIELDS})
        problems = self.params.problems()
        if problems:
            raise ValueError("; ".join(problems))
        self.input = p.input
        self.target_frame = p.target_frame or p.output_frame_id
        if not self.target_frame:
            raise ValueError("~target_frame must name a frame")
        self.height_frame = p.height_frame or self.target_frame
        self.projector = DepthProjector(self.params)
        self.camera_info = None
        self.published = self.dropped = 0
        self.last_problem = ""
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.pub = rospy.Publisher("scan", LaserScan, queue_size=2)
        self.diag = Diagnostics("pointcloud_to_laserscan")
        self.rate = self.diag.frequency("Input rate", 5.0, 60.0)
        self.diag.add("Scans", self._diagnose)
        if self.input == "cloud":
            self.subs = [rospy.Subscriber("cloud_in", PointCloud2, self.on_cloud, queue_size=1, buff_size=2 ** 24)]
        else:
            self.subs = [rospy.Subscriber("camera_info", CameraInfo, self.on_camera_info, queue_size=1),
                         rospy.Subscriber("image", Image, self.on_image, queue_size=1, buff_size=2 ** 24)]

    def _diagnose(self, stat):
        stat.summary(WARN if self.dropped else OK, f"{self.dropped} input(s) dropped" if self.dropped else
                     f"publishing from the {self.input}")
        stat.add("scans published", self.published)
        stat.add("inputs dropped", self.dropped)
        stat.add("last problem", self.last_problem)
        return stat

    def transforms(self, source_frame):
        source_frame = source_frame.lstrip("/")  # tf2 refuses the tf1-style leading "/"
        if not source_frame:
            raise ValueError("input has no frame_id")
        lookup = self.tf_buffer.lookup_transform
        t_target = to_matrix(lookup(self.target_frame, source_frame, rospy.Time(0)))
        t_height = t_target if self.height_frame == self.target_frame else \
            to_matrix(lookup(self.height_frame, source_frame, rospy.Time(0)))
        return t_target, t_height

    def publish(self, header, ranges):
        p = self.params
        scan = LaserScan(header=Header(stamp=header.stamp, frame_id=self.target_frame),
                         angle_min=p.angle_min, angle_max=p.angle_max, angle_increment=p.angle_increment,
                         time_increment=0.0, scan_time=p.scan_time, range_min=p.range_min, range_max=p.range_max)
        scan.ranges = ranges.tolist()
        self.pub.publish(scan)
        self.published += 1

    def guarded(self, convert, msg):
        self.rate.tick()
        try:
            self.publish(msg.header, convert(msg))
        except (ValueError, TypeError, tf2_ros.TransformException) as exc:
            self.dropped += 1
            self.last_problem = f"{type(exc).__name__}: {exc}"
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
        z = depth_image_metres(msg)
        return self.projector.ranges(z, info.K, t_target, t_height)


def main():
    run(PointCloudToLaserScanNode, "pointcloud_to_laserscan")
