"""create_emulator: an emulated iRobot Create on a pseudo-terminal, for the real turtlebot_node.

Start it, point turtlebot_node's ~port at ~link (or at the printed pty), and the
driver talks to the emulator exactly as to the robot.

ROS Parameters: PARAMS below (rendered in the README).

ROS Publishers:
    ~ground_truth (nav_msgs/Odometry): the emulated robot's true pose (from where it started).

ROS Subscribers:
    ~bumper (std_msgs/UInt8): bits of sensor packet 7 (bumps and wheel drops) to report.

Also sets ~pty (str) to the pseudo-terminal's path and prints it.
"""

import rospy
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt8

from florence_common.params import FRAME, Param, ParamTable
from florence_common.pty_device import PtyDevice
from florence_common_ros.convert import pose_msg
from florence_common_ros.node import read_params, run
from turtlebot_node.create_emulator import CreateEmulator

PARAMS = ParamTable(
    Param("link", str, "", 'symlink made to point at the pty (e.g. /tmp/create); "" for none'),
    Param("gyro_zero", float, 512.0, "analog reading of the gyro at rest", unit="counts", gt=0, lt=1023),
    Param("gyro_range", float, 150.0, "full-scale rate of the emulated gyro", unit="deg/s", gt=0),
    Param("gyro_gain", float, 1.0, "the emulated gyro reads 1/gain of the true rate; the driver needs "
          "gyro_scale_correction = gain", gt=0),
    Param("ground_truth_rate", float, 10.0, "rate of ~ground_truth", unit="Hz", gt=0),
    Param("frame_id", FRAME, "odom", "frame of ~ground_truth"),
)


class CreateEmulatorNode:
    def __init__(self):
        p = read_params(PARAMS)
        self.frame_id = p.frame_id
        self.core = CreateEmulator(gyro_zero=p.gyro_zero, gyro_range=p.gyro_range, gyro_gain=p.gyro_gain)
        self.truth_pub = rospy.Publisher("~ground_truth", Odometry, queue_size=5)
        self.device = PtyDevice(self.core, link=p.link or None).start()
        rospy.set_param("~pty", self.device.path)
        print(f"create_emulator: serving on {self.device.port}", flush=True)
        rospy.Subscriber("~bumper", UInt8, self._on_bumper, queue_size=5)
        self.timer = rospy.Timer(rospy.Duration(1.0 / p.ground_truth_rate), self._publish_truth)

    def shutdown(self):
        self.device.close()

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
        msg.pose.pose = pose_msg(x, y, theta)
        msg.twist.twist.linear.x = speed
        msg.twist.twist.angular.z = rate
        self.truth_pub.publish(msg)


def main():
    run(CreateEmulatorNode, "create_emulator")
