"""laser_filter_node: clears the costmap through out-of-range beams (seed 3.5, Table 7).

ROS Parameters:
    ~robot_radius (float, 0.18, m): readings nearer than this to the laser are the
        robot's own structure (the farthest standoff of plate_1 is 0.171 m from the
        Hokuyo) and are replaced like out-of-range readings.

Subscribers:
    scan (sensor_msgs/LaserScan): the scan (the seed's launch remaps it to scan_combined).

Publishers:
    filtered_scan (sensor_msgs/LaserScan): the same scan with robot returns and
        out-of-range readings (>= range_max, <= range_min, NaN, inf) set to
        range_max - 1e-4. Intensities are kept when they match the ranges in length,
        dropped (with a throttled warning) otherwise. A scan whose range limits are not
        usable is dropped with a throttled warning.
"""

import math

import rospy
from sensor_msgs.msg import LaserScan

from laser_filter.filter import filter_ranges, limits_problem

LOG = "laser_filter: "


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
        self.robot_radius = float(rospy.get_param("~robot_radius", 0.18))
        if not (math.isfinite(self.robot_radius) and self.robot_radius >= 0):
            raise ValueError(f"~robot_radius must be a finite number >= 0 [m], got {self.robot_radius}")
        self.pub = rospy.Publisher("filtered_scan", LaserScan, queue_size=5)
        self.sub = rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=5)

    def on_scan(self, msg):
        try:
            out, note = filtered_scan(msg, self.robot_radius)
        except (ValueError, TypeError) as exc:  # malformed ranges (e.g. non-numeric)
            out, note = None, f"malformed scan: {exc}"
        if note:
            rospy.logwarn_throttle(5.0, LOG + ("dropped a scan: " if out is None else "") + note)
        if out is not None:
            self.pub.publish(out)


def main():
    rospy.init_node("laser_filter_node")
    try:
        LaserFilterNode()
    except (ValueError, TypeError) as exc:
        rospy.logfatal(LOG + "bad parameters: %s", exc)
        raise SystemExit(1) from exc
    rospy.spin()
