"""turtlebot_node: the iRobot Create base of the TurtleBot over its Open Interface (seed 2.3, Table 5).

ROS Parameters: PARAMS below (rendered in the README); ~diagnostic_period (float, 1.0, s) is
read by diagnostic_updater.

ROS Publishers:
    ~sensor_state (turtlebot_node/TurtlebotSensorState): latest sensors at update_rate;
        distance [m] and angle [rad] are the raw increments since the previous message.
    odom (nav_msgs/Odometry): pose and velocity in odom_frame.
    imu/data (sensor_msgs/Imu): gyro rate and integrated yaw (has_gyro only, once its zero is known).
    /diagnostics (diagnostic_msgs/DiagnosticArray): battery, OI mode, serial link, at 1 Hz.
    /tf (tf2_msgs/TFMessage): odom_frame -> base_frame when publish_tf.

ROS Subscribers:
    cmd_vel (geometry_msgs/Twist): linear.x [m/s], angular.z [rad/s].

ROS Services:
    ~set_operation_mode (turtlebot_node/SetTurtlebotMode): 1 passive, 2 safe, 3 full.
    ~set_digital_outputs (turtlebot_node/SetDigitalOutputs): the three cargo-bay outputs.
"""

import math
import threading
import time

import rospy
import tf2_ros
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry as OdometryMsg
from sensor_msgs.msg import Imu

from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.convert import quaternion_msg, transform_stamped
from florence_common_ros.diagnostics import Diagnostics
from florence_common_ros.node import read_params, run
from turtlebot_node import create_oi
from turtlebot_node import oi_spec as oi
from turtlebot_node.msg import TurtlebotSensorState
from turtlebot_node.odometry import Gyro, Odometry
from turtlebot_node.srv import (
    SetDigitalOutputs,
    SetDigitalOutputsResponse,
    SetTurtlebotMode,
    SetTurtlebotModeResponse,
)
from turtlebot_node.transport import CreateLink

DRIVE_MODES = ("twist", "drive")
BOOL_FIELDS = ("wall", "cliff_left", "cliff_front_left", "cliff_front_right", "cliff_right", "virtual_wall",
               "song_playing")
# Covariances as the original driver published them: yaw from the gyro is trusted, the rest is planar.
ODOM_POSE_COVARIANCE = (1e-3, 1e-3, 1e6, 1e6, 1e6, 1e-3)
ODOM_TWIST_COVARIANCE = (1e-3, 1e-3, 1e6, 1e6, 1e6, 1e-3)
IMU_COVARIANCE = [1e6, 0, 0, 0, 1e6, 0, 0, 0, 1e-6]


PARAMS = ParamTable(
    Param("port", str, "/dev/ttyUSB0", "serial port of the Create"),
    Param("baud", int, 57600, "serial speed (the OI default)", unit="baud", choices=tuple(sorted(oi.BAUD_CODES))),
    Param("operation_mode", int, oi.MODE_FULL, "OI mode entered on start-up and after every reconnect: 1 passive, "
          "2 safe, 3 full", choices=tuple(sorted(oi.MODE_OPCODES))),
    Param("update_rate", float, 10.0, "rate of ~sensor_state, odom, imu/data and tf", unit="Hz", gt=0),
    Param("drive_mode", str, "twist", '"twist" sends Drive Direct (145) wheel velocities, "drive" sends Drive (137) '
          "velocity and radius", choices=DRIVE_MODES),
    Param("cmd_vel_timeout", float, 0.6, "the motors stop when no cmd_vel arrived for this long", unit="s", gt=0),
    Param("stop_motors_on_bump", bool, True, "while a bumper is pressed forward motion is refused (turning and "
          "reversing stay allowed)"),
    Param("has_gyro", bool, True, "a gyro sits on the cargo-bay analog input; odometry takes its heading from it "
          "and imu/data is published"),
    Param("gyro_measurement_range", float, 150.0, "full-scale rate of the gyro", unit="deg/s", gt=0),
    Param("gyro_scale_correction", float, 1.35, "calibration factor of the gyro rate", gt=0),
    Param("odom_angular_scale_correction", float, 1.0, "factor on the Create's angle", gt=0),
    Param("odom_linear_scale_correction", float, 1.0, "factor on the Create's distance", gt=0),
    Param("publish_tf", bool, False, "broadcast odom_frame -> base_frame"),
    Param("odom_frame", FRAME, "odom", "frame of the odometry"),
    Param("base_frame", FRAME, "base_footprint", "the robot's frame"),
    Param("gyro_frame", FRAME, "gyro_link", "frame of imu/data"),
    Param("reconnect_interval", float, 1.0, "wait between attempts to reopen a lost port", unit="s", gt=0),
    Param("stall_timeout", float, 1.0, "with no sensor frame for this long the OI is set up again", unit="s", gt=0),
)


def diagonal(values):
    cov = [0.0] * 36
    for i, v in enumerate(values):
        cov[i * 7] = v
    return cov


class TurtlebotNode:
    def __init__(self):
        p = read_params(PARAMS)
        self.p = p
        self.lock = threading.Lock()
        gyro = Gyro(p["gyro_measurement_range"], p["gyro_scale_correction"]) if p["has_gyro"] else None
        self.odometry = Odometry(gyro, p["odom_linear_scale_correction"], p["odom_angular_scale_correction"],
                                 oi.STREAM_PERIOD)
        self.publish_period = 1.0 / p["update_rate"]  # [s]
        self.last_publish = 0.0
        self.delta_distance = 0  # [mm] since the last ~sensor_state
        self.delta_angle = 0  # [deg]
        self.last_frame = None
        self.cmd = (0.0, 0.0)  # [m/s], [rad/s] last cmd_vel
        self.cmd_time = None  # time.monotonic() of the last cmd_vel
        self.sent = None  # last wheel command bytes
        self.bumped = False

        # Publishers before anything can call back.
        self.sensor_pub = rospy.Publisher("~sensor_state", TurtlebotSensorState, queue_size=5)
        self.odom_pub = rospy.Publisher("odom", OdometryMsg, queue_size=5)
        self.imu_pub = rospy.Publisher("imu/data", Imu, queue_size=5) if p["has_gyro"] else None
        self.tf_broadcaster = tf2_ros.TransformBroadcaster() if p["publish_tf"] else None
        self.diag = Diagnostics(f"iRobot Create on {p['port']}")
        self.diag.add("Battery", self._diag_battery)
        self.diag.add("Open Interface", self._diag_mode)
        self.diag.add("Serial link", self._diag_serial)
        self._last_error_total = 0

        self.link = CreateLink(p["port"], int(p["baud"]), p["operation_mode"], self._on_frame,
                               reconnect_interval=p["reconnect_interval"], stall_timeout=p["stall_timeout"])
        rospy.Service("~set_operation_mode", SetTurtlebotMode, self._set_mode)
        rospy.Service("~set_digital_outputs", SetDigitalOutputs, self._set_outputs)
        rospy.Subscriber("cmd_vel", Twist, self._on_cmd_vel, queue_size=1)
        self.link.start()
        rospy.loginfo("turtlebot_node: driving the Create on %s at %d baud, mode %s", p["port"], p["baud"],
                      oi.MODE_NAMES[p["operation_mode"]])

    # --- commands ---------------------------------------------------------------------------------
    def _wheel_command(self, linear, angular):
        if self.p["drive_mode"] == "drive":
            if abs(angular) < 1e-6:
                return create_oi.command_drive(linear * 1000.0, None)
            if abs(linear) < 1e-6:
                speed = abs(angular) * oi.WHEEL_BASE / 2.0 * 1000.0
                return create_oi.command_drive(speed, oi.RADIUS_TURN_CCW if angular > 0 else oi.RADIUS_TURN_CW)
            return create_oi.command_drive(linear * 1000.0, linear / angular * 1000.0)
        return create_oi.command_drive_direct(*create_oi.twist_to_wheels(linear, angular))

    def _send_motion(self):
        """Send the current command (zero once cmd_vel timed out; no forward motion into a bump)."""
        with self.lock:
            linear, angular = self.cmd
            if self.cmd_time is None or time.monotonic() - self.cmd_time > self.p["cmd_vel_timeout"]:
                linear = angular = 0.0
            if self.bumped and self.p["stop_motors_on_bump"] and linear > 0.0:
                linear = 0.0
            command = self._wheel_command(linear, angular)
            if command == self.sent:
                return  # a command is said once, not with every 15 ms frame
            self.sent = command
        self.link.write(command)

    def _on_cmd_vel(self, msg):
        if not all(math.isfinite(v) for v in (msg.linear.x, msg.angular.z)):
            rospy.logwarn_throttle(5.0, "turtlebot_node: ignoring non-finite cmd_vel")
            return
        with self.lock:
            self.cmd = (msg.linear.x, msg.angular.z)
            self.cmd_time = time.monotonic()
            self.sent = None
        self._send_motion()

    def _set_mode(self, req):
        if req.mode not in oi.MODE_OPCODES:
            rospy.logwarn("turtlebot_node: ~set_operation_mode: %d is not 1, 2 or 3", req.mode)
            return SetTurtlebotModeResponse(valid_mode=False)
        self.link.set_mode(req.mode)
        rospy.loginfo("turtlebot_node: OI mode %s requested", oi.MODE_NAMES[req.mode])
        return SetTurtlebotModeResponse(valid_mode=True)

    def _set_outputs(self, req):
        done = self.link.set_digital_outputs(req.digital_out_0, req.digital_out_1, req.digital_out_2)
        return SetDigitalOutputsResponse(done=done)

    # --- sensors (serial thread) ----------------------------------------------------------------------
    def _on_frame(self, frame, t):
        if not self.odometry.update(frame):
            rospy.logwarn_throttle(5.0, "turtlebot_node: implausible distance/angle in a sensor frame, skipped")
            return
        self.delta_distance += frame["distance"]
        self.delta_angle += frame["angle"]
        self.last_frame = frame
        bumped = bool(frame["bumps_wheeldrops"] & (oi.BUMP_LEFT | oi.BUMP_RIGHT))
        if bumped != self.bumped:
            with self.lock:
                self.bumped = bumped
                self.sent = None
        self._send_motion()
        if t - self.last_publish >= self.publish_period * 0.999:
            self.last_publish = t
            self._publish(frame)

    def _publish(self, frame):
        stamp = rospy.Time.now()
        state = TurtlebotSensorState()
        state.header.stamp = stamp
        for name, value in frame.items():
            setattr(state, name, bool(value) if name in BOOL_FIELDS else value)
        state.distance = self.delta_distance / 1000.0
        state.angle = math.radians(self.delta_angle)
        self.delta_distance = self.delta_angle = 0
        out = self.link.digital_outputs
        state.user_digital_outputs = (1 if out[0] else 0) | (2 if out[1] else 0) | (4 if out[2] else 0)
        self.sensor_pub.publish(state)

        pose = self.odometry.pose
        odom = OdometryMsg()
        odom.header.stamp = stamp
        odom.header.frame_id = self.p["odom_frame"]
        odom.child_frame_id = self.p["base_frame"]
        odom.pose.pose.position.x = pose.x
        odom.pose.pose.position.y = pose.y
        odom.pose.pose.orientation = quaternion_msg(pose.theta)
        odom.pose.covariance = diagonal(ODOM_POSE_COVARIANCE)
        odom.twist.twist.linear.x = pose.linear
        odom.twist.twist.angular.z = pose.angular
        odom.twist.covariance = diagonal(ODOM_TWIST_COVARIANCE)
        self.odom_pub.publish(odom)

        if self.tf_broadcaster is not None:
            self.tf_broadcaster.sendTransform(transform_stamped(stamp, self.p["odom_frame"], self.p["base_frame"],
                                                                pose.x, pose.y, pose.theta))

        if self.imu_pub is not None and self.odometry.gyro_rate is not None:
            imu = Imu()
            imu.header.stamp = stamp
            imu.header.frame_id = self.p["gyro_frame"]
            imu.orientation = quaternion_msg(self.odometry.gyro.orientation)
            imu.orientation_covariance = IMU_COVARIANCE
            imu.angular_velocity.z = self.odometry.gyro_rate
            imu.angular_velocity_covariance = IMU_COVARIANCE
            imu.linear_acceleration_covariance[0] = -1.0  # not measured
            self.imu_pub.publish(imu)

    # --- diagnostics ---------------------------------------------------------------------------------------
    def _diag_battery(self, stat):
        frame = self.last_frame
        if frame is None:
            stat.summary(DiagnosticStatus.WARN, "no sensor data yet")
            return stat
        fraction = frame["charge"] / frame["capacity"] if frame["capacity"] else 0.0
        level = DiagnosticStatus.OK if fraction >= 0.2 else DiagnosticStatus.WARN if fraction >= 0.1 \
            else DiagnosticStatus.ERROR
        stat.summary(level, f"{100.0 * fraction:.0f}% charged, "
                            f"{oi.CHARGING_STATE_NAMES.get(frame['charging_state'], 'unknown')}")
        stat.add("Voltage (V)", f"{frame['voltage'] / 1000.0:.2f}")
        stat.add("Current (A)", f"{frame['current'] / 1000.0:.3f}")
        stat.add("Charge (Ah)", f"{frame['charge'] / 1000.0:.3f}")
        stat.add("Capacity (Ah)", f"{frame['capacity'] / 1000.0:.3f}")
        stat.add("Temperature (C)", frame["temperature"])
        stat.add("Charging state", oi.CHARGING_STATE_NAMES.get(frame["charging_state"], "unknown"))
        return stat

    def _diag_mode(self, stat):
        frame = self.last_frame
        if frame is None:
            stat.summary(DiagnosticStatus.WARN, "OI mode unknown (no sensor data)")
            return stat
        mode = frame["oi_mode"]
        level = DiagnosticStatus.OK if mode in (oi.MODE_SAFE, oi.MODE_FULL) else DiagnosticStatus.WARN
        stat.summary(level, f"OI mode {oi.MODE_NAMES.get(mode, mode)}")
        stat.add("OI mode", oi.MODE_NAMES.get(mode, str(mode)))
        stat.add("Requested mode", oi.MODE_NAMES[self.link.mode])
        stat.add("Bumps and wheel drops", frame["bumps_wheeldrops"])
        stat.add("Gyro zero (counts)", "" if self.odometry.gyro is None or self.odometry.gyro.offset is None
                 else f"{self.odometry.gyro.offset:.2f}")
        return stat

    def _diag_serial(self, stat):
        health = self.link.health()
        errors = (health["checksum_errors"] + health["partial_frames"] + health["stalls"] + health["write_errors"]
                  + self.odometry.rejected)
        if not health["connected"]:
            stat.summary(DiagnosticStatus.ERROR, f"not connected: {health['last_error']}")
        elif errors > self._last_error_total:
            stat.summary(DiagnosticStatus.WARN, f"{errors - self._last_error_total} new serial errors")
        else:
            stat.summary(DiagnosticStatus.OK, "receiving sensor stream")
        self._last_error_total = errors
        stat.add("Port", self.p["port"])
        for key in ("connected", "connects", "disconnects", "frames", "checksum_errors", "garbage_bytes",
                    "partial_frames", "stalls", "write_errors", "modem_lines", "last_error"):
            stat.add(key, health[key])
        stat.add("implausible_frames", self.odometry.rejected)
        return stat

    def shutdown(self):
        """Stop the motors, then close the port."""
        self.diag.shutdown()
        self.link.stop(safe_bytes=self._wheel_command(0.0, 0.0))


def main():
    run(TurtlebotNode, "turtlebot_node")
