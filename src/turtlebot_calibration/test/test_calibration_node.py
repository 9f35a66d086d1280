"""calibrate.py on a private master, fed by this test (no simulator): inputs that are missing or
useless end it with exit status 1, a message naming what is wrong, and the robot stopped."""

import math
import threading
import time

import pytest

from florence_common.processes import rosrun, wait_for

pytestmark = pytest.mark.ros

NAME = "calibration_test"  # not the launch files' turtlebot_calibration: rosrun leaves the private parameters set
QUICK = [f"__name:={NAME}", "_input_timeout:=2.0", "_wall_timeout:=1.0", "_scan_timeout:=1.0",
         "_imu_calibrate_time:=0.5"]


class Feeder:
    """Publishes what the base and a laser would, at 10 Hz, in a thread: ``scan`` ranges (or None: no
    scan), the gyro and the wheel angle (flags). Records every cmd_vel the node sends."""

    def __init__(self, rospy, publisher, ranges=None, gyro=True, odom=True):
        from geometry_msgs.msg import Twist
        from sensor_msgs.msg import Imu, LaserScan

        from turtlebot_node.msg import TurtlebotSensorState

        self.rospy, self.ranges, self.gyro, self.odom = rospy, ranges, gyro, odom
        self.pubs = {"scan": publisher("/scan", LaserScan), "imu": publisher("/imu", Imu),
                     "state": publisher("/turtlebot_node/sensor_state", TurtlebotSensorState)}
        self.classes = (LaserScan, Imu, TurtlebotSensorState)
        self.commands = []
        self.sub = rospy.Subscriber("/cmd_vel", Twist, lambda m: self.commands.append(m.angular.z), queue_size=50)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        LaserScan, Imu, State = self.classes
        while not self.stop.is_set():
            stamp = self.rospy.Time.now()
            if self.ranges is not None:
                scan = LaserScan()
                scan.header.stamp, scan.header.frame_id = stamp, "base_footprint"
                scan.angle_min, scan.angle_increment = -1.0, 2.0 / (len(self.ranges) - 1)
                scan.angle_max, scan.range_min, scan.range_max = 1.0, 0.02, 5.6
                scan.ranges = self.ranges
                self.pubs["scan"].publish(scan)
            if self.gyro:  # None: silent
                imu = Imu()
                imu.header.stamp, imu.orientation.w = stamp, 1.0
                self.pubs["imu"].publish(imu)
            if self.odom:
                state = State()
                state.header.stamp = stamp
                self.pubs["state"].publish(state)
            time.sleep(0.1)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()
        self.sub.unregister()


@pytest.fixture(autouse=True)
def forget_parameters(rospy_node):
    yield
    if rospy_node.has_param(f"/{NAME}"):
        rospy_node.delete_param(f"/{NAME}")


def calibrate(ros_master, *args):
    """Run calibrate.py to its end; (exit status, output)."""
    proc = rosrun(ros_master, "turtlebot_calibration", "calibrate.py", "scan:=/scan", "imu:=/imu", *QUICK, *args)
    try:
        wait_for(lambda: not proc.running(), 60.0, what="calibrate.py to end")
    finally:
        status = proc.stop()
    return status, proc.output()


def test_no_scan_and_no_odometry(ros_master, rospy_node, publisher, wall_time):
    """Only the gyro speaks: the laser and the base are named, each with what to check."""
    with Feeder(rospy_node, publisher, ranges=None, odom=False):
        status, out = calibrate(ros_master)
    assert status == 1, out
    assert "cannot calibrate: nothing came in 2 s" in out
    assert "no scan on /scan: is the laser" in out
    assert "no odometry on /turtlebot_node/sensor_state: is turtlebot_node" in out
    assert "no gyro" not in out
    assert "Traceback" not in out


def test_no_wall_in_front(ros_master, rospy_node, publisher, wall_time):
    with Feeder(rospy_node, publisher, ranges=[math.inf] * 200) as feeder:
        status, out = calibrate(ros_master)
    assert status == 1, out
    assert "cannot calibrate: no wall in front: 0 readings within 20 deg of straight ahead" in out
    assert "Place the robot" in out
    assert "Traceback" not in out
    assert feeder.commands and feeder.commands[-1] == 0.0  # stopped


@pytest.mark.parametrize("silent, message", [
    ("ranges", "cannot calibrate: no scan for 1.0 s (no message on /scan)"),
    ("gyro", "cannot calibrate: no gyro message on /imu for "),
])
def test_an_input_stops_in_the_middle(ros_master, rospy_node, publisher, silent, message):
    """A wall 1 m ahead (a laser in base_footprint, beams -1..1 rad), then the laser or the gyro goes
    silent during the drift measurement."""
    ranges = [1.0 / math.cos(-1.0 + 2.0 * i / 199) for i in range(200)]
    with Feeder(rospy_node, publisher, ranges=ranges) as feeder:
        proc = rosrun(ros_master, "turtlebot_calibration", "calibrate.py", "scan:=/scan", "imu:=/imu", *QUICK)
        try:
            wait_for(lambda: "Estimating imu drift" in proc.output(), 30.0, what="the drift measurement")
            setattr(feeder, silent, None)
            wait_for(lambda: not proc.running(), 30.0, what="calibrate.py to end")
        finally:
            status = proc.stop()
    out = proc.output()
    assert status == 1, out
    assert message in out
    assert "Traceback" not in out
    assert feeder.commands[-1] == 0.0
