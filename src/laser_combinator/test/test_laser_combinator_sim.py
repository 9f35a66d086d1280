"""The filter chain on florence_sim's sensors: depth image -> /kinect_scan,
/scan + /kinect_scan -> /scan_combined -> /filtered_scan, with the robot in front of the
dining table and a chair (which the low laser sees only as thin legs)."""

import math

import numpy as np
import pytest

from florence_common.processes import roslaunch, rosrun, stop_all, wait_for

pytestmark = pytest.mark.scenario


# The robot at (1.3, 4.3) facing east: the dining table (x 2.8..4.0, y 3.4..4.2, top 0.75 m)
# and chair_west (seat 0.45 m at x 2.45, y 3.8) lie ahead and to the robot's RIGHT only.
POSE = ["x:=1.3", "y:=4.3", "yaw:=0.0"]


@pytest.fixture(scope="module")
def chain(ros_master, rospy_node, tmp_path_factory):
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import LaserScan

    nobody = tmp_path_factory.mktemp("sim") / "nobody.yaml"
    nobody.write_text("people: []\n")
    procs = [roslaunch(ros_master, "florence_sim", "florence_sim.launch", *POSE, f"people:={nobody}")]
    topics = {"scan": [], "kinect_scan": [], "scan_combined": [], "filtered_scan": []}
    subs = [rospy_node.Subscriber(f"/{name}", LaserScan, lambda m, name=name: topics[name].append(m))
            for name in topics]
    clock = []
    subs.append(rospy_node.Subscriber("/clock", Clock, clock.append))
    try:
        wait_for(lambda: clock, 60.0, what="simulated /clock")  # /use_sim_time is set before the nodes start
        procs += [
            rosrun(ros_master, "pointcloud_to_laserscan", "pointcloud_to_laserscan_node", "__name:=kinect_laser",
                   "_input:=depth", "image:=/camera/depth/image", "camera_info:=/camera/depth/camera_info",
                   "scan:=/kinect_scan", "_min_height:=0.05", "_max_height:=1.0"),
            rosrun(ros_master, "laser_combinator", "laser_combinator_node", "__name:=laser_combinator_node"),
            rosrun(ros_master, "laser_filter", "laser_filter_node", "__name:=laser_filter_node",
                   "scan:=/scan_combined"),
        ]
        wait_for(lambda: len(topics["filtered_scan"]) >= 5, 90.0, what="filtered scans from the simulated sensors")
        yield topics
    finally:
        for s in subs:
            s.unregister()
        stop_all(*procs)
        if rospy_node.has_param("/use_sim_time"):
            rospy_node.delete_param("/use_sim_time")  # later tests on this master run on wall time


def test_kinect_scan_from_the_simulated_depth_image(chain):
    scan = chain["kinect_scan"][-1]
    assert scan.header.frame_id == "camera_depth_frame"
    r = np.array(scan.ranges)
    seen = np.flatnonzero(np.isfinite(r))
    angles = scan.angle_min + (seen + 0.5) * scan.angle_increment
    assert seen.size > 20
    assert np.all(np.abs(angles) <= math.radians(29.5))  # the Kinect's 58 degree field of view
    assert np.all((r[seen] >= 0.45) & (r[seen] <= 4.0))


def test_combined_scan_adds_what_only_the_kinect_sees_on_the_correct_side(chain):
    by_stamp = {m.header.stamp: m for m in chain["scan"]}
    pairs = [(by_stamp[c.header.stamp], c) for c in chain["scan_combined"] if c.header.stamp in by_stamp]
    assert pairs, "no combined scan matched a laser scan by stamp"
    laser, combined = pairs[-1]
    assert combined.header.frame_id == "base_laser_round_link" and combined.range_max == pytest.approx(4.0)
    h, c = np.array(laser.ranges), np.array(combined.ranges)
    assert h.size == c.size
    valid = (h >= laser.range_min) & (h <= laser.range_max)
    assert np.all(c[valid] <= h[valid] + 1e-6), "the combined scan is never farther than the laser"
    # Table top and chair seat are more than 1 m nearer than the wall the laser sees behind them;
    # 0.5 m keeps apart the few centimetres by which a Kinect beam (0.5 degrees, wider than the
    # laser's 0.35) can undercut a wall seen at a grazing angle.
    kinect_only = np.flatnonzero(valid & (c < h - 0.5))
    assert kinect_only.size >= 5, "table top and chair seat, seen by the Kinect only, are missing"
    angles = combined.angle_min + kinect_only * combined.angle_increment
    # The robot's right is the upside-down laser's positive side.
    assert np.all(angles > 0), f"Kinect-only returns at laser angles {np.round(angles, 3)}"


def test_filtered_scan_is_all_returns_or_clearing_beams(chain):
    scan = chain["filtered_scan"][-1]
    r = np.array(scan.ranges)
    assert np.all(np.isfinite(r))
    assert np.all((r >= 0.18) & (r <= scan.range_max - 1e-4 + 1e-6))
    assert np.count_nonzero(np.isclose(r, scan.range_max - 1e-4)) > 0  # beyond 4 m: cleared
