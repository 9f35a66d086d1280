"""create_emulator: an emulated iRobot Create on a pseudo-terminal, for the real turtlebot_node.

Start it, point turtlebot_node's ~port at ~link (or at the printed pty), and the
driver talks to the emulator exactly as to the robot.

ROS Parameters:
    ~link (str, ""): symlink made to point at the pty (e.g. /tmp/create); "" for none.
    ~gyro_zero (float, 512.0, counts): analog reading of the gyro at rest.
    ~gyro_range (float, 150.0, deg/s): full-scale rate of the emulated gyro.
    ~gyro_gain (float, 1.0): the emulated gyro reads 1/gain of the true rate; the driver
        needs gyro_scale_correction = gain.
    ~ground_truth_rate (float, 10.0, Hz): rate of ~ground_truth.
    ~frame_id (str, "odom"): frame of ~ground_truth.

ROS Publishers:
    ~ground_truth (nav_msgs/Odometry): the emulated robot's true pose (from where it started).

ROS Subscribers:
    ~bumper (std_msgs/UInt8): bits of sensor packet 7 (bumps and wheel drops) to report.

Also sets ~pty (str) to the pseudo-terminal's path and prints it.
"""

import math
import sys

import rospy
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt8

from florence_common.pty_device import PtyDevice
from turtlebot_node.create_emulator import CreateEmulator


class CreateEmulatorNode:
    def __init__(self):
        link = rospy.get_param("~link", "") or None
        gyro_zero = float(rospy.get_param("~gyro_zero", 512.0))
        gyro_range = float(rospy.get_param("~gyro_range", 150.0))
        gyro_gain = float(rospy.get_param("~gyro_gain", 1.0))
        rate = float(rospy.get_param("~ground_truth_rate", 10.0))
        self.frame_id = rospy.get_param("~frame_id", "odom")
        if not (0.0 < gyro_zero < 1023.0 and gyro_range > 0.0 and gyro_gain > 0.0 and rate > 0.0):
            rospy.logfatal("create_emulator: need 0 < ~gyro_zero < 1023 and positive ~gyro_range, ~gyro_gain, "
                           "~ground_truth_rate")
            sys.exit(1)
        self.core = CreateEmulator(gyro_zero=gyro_zero, gyro_range=gyro_range, gyro_gain=gyro_gain)
        self.truth_pub = rospy.Publisher("~ground_truth", Odometry, queue_size=5)
        self.device = PtyDevice(self.core, link=link).start()
        rospy.set_param("~pty", self.device.path)
        print(f"create_emulator: serving on {self.device.port}", flush=True)
        rospy.Subscriber("~bumper", UInt8, self._on_bumper, queue_size=5)
        self.timer = rospy.Timer(rospy.Duration(1.0 / rate), self._publish_truth)
        rospy.on_shutdown(self.device.close)

    def _on_bumper(self, msg):
        with self.core.lock:
            self.core.bumps_wheeldrops = msg.data & 0x1F

    def _publish_truth(self, _event):
        with self.core.lock:
            x, y, theta, rate = self.core.x, self.core.y, self.core.theta, self.core.true_rate()
            speed = (self.core.right + self.core.left) / 2000.0
        msg = Odometry()
        msg.header.stamp = rospy.Time.now()
        msg.header.frame_id = self.frame_id
        msg.pose.pose.position.x = x
        msg.pose.pose.position.y = y
        msg.pose.pose.orientation.z = math.sin(theta / 2.0)
        msg.pose.pose.orientation.w = math.cos(theta / 2.0)
        msg.twist.twist.linear.x = speed
        msg.twist.twist.angular.z = rate
        self.truth_pub.publish(msg)


def main():
    rospy.init_node("create_emulator")
    CreateEmulatorNode()
    rospy.spin()
