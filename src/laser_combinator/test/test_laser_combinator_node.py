"""laser_combinator_node with the real robot description (robot_state_publisher tf):
nearer reading per angle with the upside-down laser, Table 10 fields, freshness, bad frames."""

import math
import time

import numpy as np
import pytest

from florence_common.processes import ManagedProcess, roslaunch, stop_all, wait_for

pytestmark = pytest.mark.ros


INC = 2 * math.pi / 1024  # [rad] URG-04LX step
N = 511  # beams within +-1.570 rad
NEAR_LASER_ANGLE = 0.5  # [rad] in base_laser_link, where the laser sees 0.6 m
KINECT_ANGLE = 0.3  # [rad] in camera_depth_frame: the robot's left, where the Kinect sees 1.0 m


def hokuyo_scan():
    from sensor_msgs.msg import LaserScan

    ranges = np.full(N, 3.0)
    ranges[round((NEAR_LASER_ANGLE + 255 * INC) / INC)] = 0.6
    scan = LaserScan(angle_min=-255 * INC, angle_max=255 * INC, angle_increment=INC, time_increment=1e-4,
                     scan_time=0.1, range_min=0.02, range_max=5.6, ranges=ranges.tolist(),
                     intensities=list(range(N)))
    scan.header.frame_id = "base_laser_link"
    return scan


def kinect_scan(frame="camera_depth_frame"):
    from sensor_msgs.msg import LaserScan

    ranges = np.full(501, np.inf)
    ranges[round((KINECT_ANGLE + 0.5) / 0.002)] = 1.0
    scan = LaserScan(angle_min=-0.5, angle_max=0.5, angle_increment=0.002, scan_time=1 / 30,
                     range_min=0.45, range_max=4.0, ranges=ranges.tolist())
    scan.header.frame_id = frame
    return scan


class Repeater:
    """Publishes ``msg`` (restamped) every ``period`` s from a rospy timer; remembers the last send."""

    def __init__(self, rospy, pub, msg, period=0.1):
        self.rospy, self.pub, self.msg, self.last_sent = rospy, pub, msg, None
        self.timer = rospy.Timer(rospy.Duration(period), self._tick)

    def _tick(self, _event):
        self.msg.header.stamp = self.rospy.Time.now()
        self.pub.publish(self.msg)
        self.last_sent = time.monotonic()

    def stop(self):
        self.timer.shutdown()
        self.timer.join()


@pytest.fixture(scope="module")
def combinator(ros_master, rospy_node, tf_buffer):
    from sensor_msgs.msg import LaserScan

    # One roslaunch at a time (a second one against the same master races for /run_id); the
    # node under test runs through rosrun with the parameters of its launch file's defaults.
    procs = [roslaunch(ros_master, "turtlebot_control", "description.launch"),
             ManagedProcess(["rosrun", "laser_combinator", "laser_combinator_node", "__name:=laser_combinator_node"],
                            env=ros_master.env())]
    out = []
    sub = rospy_node.Subscriber("/scan_combined", LaserScan, lambda m: out.append((time.monotonic(), m)))
    pubs = (rospy_node.Publisher("/scan", LaserScan, queue_size=5),
            rospy_node.Publisher("/kinect_scan", LaserScan, queue_size=5))
    try:
        wait_for(lambda: tf_buffer.can_transform("base_laser_round_link", "camera_depth_frame", rospy_node.Time(0)),
                 60.0, what="robot tf")
        wait_for(lambda: all(p.get_num_connections() for p in pubs) and sub.get_num_connections(), 30.0,
                 what="laser_combinator connected")
        yield pubs, out
    finally:
        sub.unregister()
        for p in pubs:
            p.unregister()
        stop_all(*procs)


def test_nearer_reading_per_angle_through_tf_with_the_inverted_laser(combinator, rospy_node, tf_buffer):
    import tf2_geometry_msgs
    from geometry_msgs.msg import PointStamped

    (scan_pub, kinect_pub), out = combinator
    streams = [Repeater(rospy_node, scan_pub, hokuyo_scan()), Repeater(rospy_node, kinect_pub, kinect_scan())]
    try:
        t0 = time.monotonic()
        wait_for(lambda: any(t > t0 for t, _ in out), 20.0, what="a combined scan")
    finally:
        for s in streams:
            s.stop()
    msg = out[-1][1]
    assert msg.header.frame_id == "base_laser_round_link"
    assert (msg.range_min, msg.range_max) == (pytest.approx(0.02), pytest.approx(4.0))  # Table 10
    assert len(msg.ranges) == N and list(msg.intensities) == list(range(N))
    assert msg.angle_min == pytest.approx(-255 * INC, abs=1e-6) and msg.angle_increment == pytest.approx(INC)

    # Where the Kinect's 1 m return lies in the laser frame, computed independently through tf.
    p = PointStamped()
    p.header.frame_id = "camera_depth_frame"
    p.point.x, p.point.y = math.cos(KINECT_ANGLE), math.sin(KINECT_ANGLE)
    tf = tf_buffer.lookup_transform("base_laser_round_link", "camera_depth_frame", rospy_node.Time(0))
    q = tf2_geometry_msgs.do_transform_point(p, tf).point
    bearing, distance = math.atan2(q.y, q.x), math.hypot(q.x, q.y)
    assert bearing < 0, "the robot's left is on the negative side of the upside-down laser"
    ranges = np.array(msg.ranges)
    kinect_bin = round((bearing - msg.angle_min) / msg.angle_increment)
    laser_bin = round((NEAR_LASER_ANGLE - msg.angle_min) / msg.angle_increment)
    mirror_bin = round((-bearing - msg.angle_min) / msg.angle_increment)
    assert ranges[kinect_bin] == pytest.approx(distance, abs=1e-4)  # Kinect nearer than the laser's 3 m
    assert ranges[laser_bin] == pytest.approx(0.6)  # laser nearer; the Kinect sees nothing there
    assert ranges[mirror_bin] == pytest.approx(3.0)
    others = np.delete(ranges, [kinect_bin, laser_bin])
    assert others == pytest.approx(np.full(N - 2, 3.0))


def test_stale_laser_and_unknown_frames_stop_output_until_inputs_are_good_again(combinator, rospy_node):
    (scan_pub, kinect_pub), out = combinator
    laser = Repeater(rospy_node, scan_pub, hokuyo_scan())
    kinect = Repeater(rospy_node, kinect_pub, kinect_scan())
    try:
        wait_for(lambda: laser.last_sent and out and out[-1][0] > laser.last_sent, 20.0, what="combined output")
        laser.stop()
        laser_last = laser.last_sent
        wait_for(lambda: kinect.last_sent > laser_last + 1.6, 20.0, what="Kinect scans 1.6 s after the laser stopped")
        assert not [t for t, _ in out if t > laser_last + 1.0 + 0.3], "published with a stale laser scan"

        kinect.stop()
        laser = Repeater(rospy_node, scan_pub, hokuyo_scan())
        kinect = Repeater(rospy_node, kinect_pub, kinect_scan(frame="no_such_frame"))
        bad_from = time.monotonic()
        wait_for(lambda: laser.last_sent and kinect.last_sent and kinect.last_sent > bad_from + 0.6, 10.0,
                 what="0.6 s of Kinect scans in an unknown frame")
        # 0.2 s grace for a good Kinect scan still in flight when the bad ones started.
        assert not [t for t, _ in out if t > bad_from + 0.2], "published from a Kinect frame tf does not know"

        kinect.stop()
        # A tf1-style frame with a leading "/" is good too (regression: tf2 refused it).
        kinect = Repeater(rospy_node, kinect_pub, kinect_scan(frame="/camera_depth_frame"))
        good_from = time.monotonic()
        wait_for(lambda: any(t > good_from for t, _ in out), 20.0, what="output once the inputs are good again")
    finally:
        laser.stop()
        kinect.stop()
