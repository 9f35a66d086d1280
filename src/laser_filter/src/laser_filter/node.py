"""laser_filter_node: clears the costmap through out-of-range beams (seed 3.5, Table 7).

ROS Parameters: PARAMS below (rendered in the README).

ROS Subscribers:
    scan (sensor_msgs/LaserScan): the scan (the seed's launch remaps it to scan_combined).

ROS Publishers:
    filtered_scan (sensor_msgs/LaserScan): the same scan with robot returns and
        out-of-range readings (>= range_max, <= range_min, NaN, inf) set to
        range_max - 1e-4. Intensities are kept when they match the ranges in length,
        dropped (with a throttled warning) otherwise. A scan whose range limits are not
        usable is dropped with a throttled warning.
    /diagnostics: the scan rate, scans filtered and dropped, the last reason.
"""

import rospy
from sensor_msgs.msg import LaserScan

from florence_common.params import Param, ParamTable
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from laser_filter.filter import filter_ranges, limits_problem

LOG = "laser_filter: "
PARAMS = ParamTable(
    Param("robot_radius", float, 0.18, "readings nearer than this to the laser are the robot's own structure (the "
          "farthest standoff of plate_1 is 0.171 m from the Hokuyo) and are replaced like out-of-range readings",
          unit="m", ge=0),
)


def filtered_scan(msg, robot_radius):
    """The output message for ``msg``, or (None, reason) when the scan cannot be filtered."""
    problem = limits_problem(msg.range_min, msg.range_max)
    if problem:
        return None, problem
    out = LaserScan(header=msg.header, angle_min=msg.angle_min, angle_max=msg.angle_max,
                    angle_increment=msg.angle_increment, time_increment=msg.time_increment,
                    scan_time=msg.scan_time, range_min=msg.range_min, range_max=msg.range_max)
    out.ranges = filter_ranges(msg.ranges, msg.range_min, msg.range_max, robot_radius).tolist()
    note = None
    if len(msg.intensities) == len(msg.ranges):
        out.intensities = msg.intensities
    else:
        note = f"{len(msg.intensities)} intensities for {len(msg.ranges)} ranges: intensities dropped"
    return out, note


class LaserFilterNode:
    def __init__(self):
        self.robot_radius = read_params(PARAMS).robot_radius
        self.filtered = self.dropped = 0
        self.last_problem = ""
        self.pub = rospy.Publisher("filtered_scan", LaserScan, queue_size=5)
        self.diag = Diagnostics("laser_filter")
        self.rate = self.diag.frequency("Scan rate", 5.0, 40.0)
        self.diag.add("Scans", self._diagnose)
        self.sub = rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=5)

    def on_scan(self, msg):
        self.rate.tick()
        try:
            out, note = filtered_scan(msg, self.robot_radius)
        except (ValueError, TypeError) as exc:  # malformed ranges (e.g. non-numeric)
            out, note = None, f"malformed scan: {exc}"
        if note:
            self.last_problem = note
            rospy.logwarn_throttle(5.0, LOG + ("dropped a scan: " if out is None else "") + note)
        if out is not None:
            self.filtered += 1
            self.pub.publish(out)
        else:
            self.dropped += 1

    def _diagnose(self, stat):
        stat.summary(WARN if self.dropped else OK, f"{self.dropped} scan(s) dropped" if self.dropped else "filtering")
        stat.add("scans filtered", self.filtered)
        stat.add("scans dropped", self.dropped)
        stat.add("last problem", self.last_problem)
        return stat


def main():
    run(LaserFilterNode, "laser_filter_node")
