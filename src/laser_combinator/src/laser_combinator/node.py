"""laser_combinator_node: Hokuyo + Kinect fake scan -> /scan_combined (seed 3.7, Tables 9-10).

ROS Parameters: PARAMS and SHARED below (rendered in the README): the combined scan covers the
Hokuyo's beams within [-max_ang, max_ang], read from the Hokuyo driver's own parameter.

ROS Subscribers:
    scan (sensor_msgs/LaserScan): the Hokuyo (upside down, in base_laser_link).
    kinect_scan (sensor_msgs/LaserScan): the Kinect fake laser (pointcloud_to_laserscan).

ROS Publishers:
    scan_combined (sensor_msgs/LaserScan): on each new Kinect scan while the Hokuyo scan
        is fresh: the Hokuyo's angular grid (cropped to max_ang) in ~frame_id, per angle
        the nearer valid reading of both sensors (+inf where neither has one), header
        stamp, time_increment, scan_time, range_min and intensities of the Hokuyo,
        range_max of the Kinect (seed Table 10). Stale inputs, unknown frames and
        malformed scans give no output and a throttled warning.
    /diagnostics: the Kinect scan rate, combined scans, the last reason for none.
"""

import math

import numpy as np
import rospy
import tf2_ros
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header

from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.convert import to_matrix
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from laser_combinator.combine import Scan, combine

LOG = "laser_combinator: "
PARAMS = ParamTable(
    Param("frame_id", FRAME, "/base_laser_round_link", "frame of the combined scan (the laser's); both inputs are "
          "brought into it through tf (seed)", check=lambda v: None if v else "must name a frame"),
    Param("kinect_frame_id", FRAME, "/camera_depth_frame", "frame of /kinect_scan when its header names none (seed)"),
    Param("max_age", float, 1.0, "both inputs must have arrived within this time", unit="s", gt=0),
)
SHARED = ParamTable(
    Param("hokuyo_node/max_ang", float, 1.570, "the Hokuyo's last angle: the combined scan covers its beams within "
          "[-max_ang, max_ang] (seed)", unit="rad", gt=0),
    prefix="",
)


def scan_from_msg(msg):
    """The core's Scan for a LaserScan message; raises ValueError if it is malformed."""
    for name in ("angle_min", "angle_increment", "range_min", "range_max"):
        if not math.isfinite(getattr(msg, name)):
            raise ValueError(f"{name} is {getattr(msg, name)}")
    if msg.angle_increment == 0 and len(msg.ranges) > 1:
        raise ValueError("angle_increment is 0")
    return Scan(msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max,
                np.asarray(msg.ranges, dtype=np.float32))


def combined_scan(hokuyo_msg, kinect_msg, t_hokuyo, t_kinect, frame_id, max_ang):
    """The /scan_combined message of two scans, given the 4x4 transforms of their frames into ``frame_id``."""
    hokuyo, kinect = scan_from_msg(hokuyo_msg), scan_from_msg(kinect_msg)
    grid, ranges, first = combine(hokuyo, kinect, t_hokuyo, t_kinect, max_ang)
    out = LaserScan(header=Header(stamp=hokuyo_msg.header.stamp, frame_id=frame_id),
                    angle_min=grid.angle_min, angle_increment=grid.angle_increment,
                    angle_max=grid.angle_min + grid.angle_increment * max(grid.size - 1, 0),
                    time_increment=hokuyo_msg.time_increment, scan_time=hokuyo_msg.scan_time,
                    range_min=hokuyo_msg.range_min, range_max=kinect_msg.range_max)
    out.ranges = ranges.tolist()
    if len(hokuyo_msg.intensities) == len(hokuyo_msg.ranges) and hokuyo_msg.angle_increment > 0:
        out.intensities = hokuyo_msg.intensities[first:first + grid.size]
    return out


class LaserCombinatorNode:
    def __init__(self):
        p, shared = read_params(PARAMS), read_params(SHARED)
        self.frame_id, self.kinect_frame_id, self.max_age = p.frame_id, p.kinect_frame_id, p.max_age
        self.max_ang = shared.hokuyo_node_max_ang
        self.combined_count = 0
        self.last_problem = ""
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.hokuyo = None  # (LaserScan, receipt time [s])
        self.pub = rospy.Publisher("scan_combined", LaserScan, queue_size=5)
        self.diag = Diagnostics("laser_combinator")
        self.kinect_rate = self.diag.frequency("Kinect scan rate", 5.0, 40.0)
        self.diag.add("Combined scans", self._diagnose)
        self.sub_scan = rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=2)
        self.sub_kinect = rospy.Subscriber("kinect_scan", LaserScan, self.on_kinect_scan, queue_size=2)

    def on_scan(self, msg):
        self.hokuyo = (msg, rospy.get_time())

    def transform_to_output(self, frame):
        # tf2 refuses a leading "/" (tf1 style, as older drivers stamp): accept it.
        return to_matrix(self.tf_buffer.lookup_transform(self.frame_id, frame.lstrip("/"), rospy.Time(0)))

    def on_kinect_scan(self, kinect_msg):
        self.kinect_rate.tick()
        try:
            out, problem = self.combined(kinect_msg)
        except (ValueError, TypeError, tf2_ros.TransformException) as exc:
            out, problem = None, f"{type(exc).__name__}: {exc}"
        if problem:
            self.last_problem = problem
            rospy.logwarn_throttle(5.0, LOG + "no combined scan: " + problem)
        if out is not None:
            self.combined_count += 1
            self.pub.publish(out)

    def _diagnose(self, stat):
        stat.summary(WARN if self.last_problem else OK, self.last_problem or "combining")
        self.last_problem = ""
        stat.add("combined scans", self.combined_count)
        return stat

    def combined(self, kinect_msg):
        """(LaserScan, None), or (None, why there is none)."""
        held = self.hokuyo
        if held is None:
            return None, "no Hokuyo scan received yet"
        hokuyo_msg, received = held
        age = rospy.get_time() - received
        if age > self.max_age:
            return None, f"the Hokuyo scan is {age:.2f} s old (> {self.max_age} s)"
        if not hokuyo_msg.header.frame_id:
            return None, "the Hokuyo scan has no frame_id"
        kinect_frame = kinect_msg.header.frame_id or self.kinect_frame_id
        t_hokuyo = self.transform_to_output(hokuyo_msg.header.frame_id)
        t_kinect = self.transform_to_output(kinect_frame)
        return combined_scan(hokuyo_msg, kinect_msg, t_hokuyo, t_kinect, self.frame_id, self.max_ang), None


def main():
    run(LaserCombinatorNode, "laser_combinator_node")
