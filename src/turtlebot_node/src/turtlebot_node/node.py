"""turtlebot_node: the iRobot Create base of the TurtleBot over its Open Interface (seed 2.3, Table 5).

ROS Parameters:
    ~port (str, "/dev/ttyUSB0"): serial port of the Create.
    ~baud (int, 57600, baud): serial speed (the OI default).
    ~operation_mode (int, 3): OI mode entered on start-up and after every reconnect:
        1 passive, 2 safe, 3 full.
    ~update_rate (float, 10.0, Hz): rate of ~sensor_state, odom, imu/data and tf.
    ~drive_mode (str, "twist"): "twist" sends Drive Direct (145) wheel velocities,
        "drive" sends Drive (137) velocity and radius.
    ~cmd_vel_timeout (float, 0.6, s): motors stop when no cmd_vel arrived for this long.
    ~stop_motors_on_bump (bool, true): while a bumper is pressed forward motion is
        refused (turning and reversing stay allowed).
    ~has_gyro (bool, true): a gyro sits on the cargo-bay analog input; odometry takes
        its heading from it and imu/data is published.
    ~gyro_measurement_range (float, 150.0, deg/s): full-scale rate of the gyro.
    ~gyro_scale_correction (float, 1.35): calibration factor of the gyro rate.
    ~odom_angular_scale_correction (float, 1.0): factor on the Create's angle.
    ~odom_linear_scale_correction (float, 1.0): factor on the Create's distance.
    ~publish_tf (bool, false): broadcast odom_frame -> base_frame.
    ~odom_frame (str, "odom"), ~base_frame (str, "base_footprint"), ~gyro_frame (str, "gyro_link").
    ~reconnect_interval (float, 1.0, s): wait between attempts to reopen a lost port.
    ~stall_timeout (float, 1.0, s): with no sensor frame for this long the OI is set up again.
    ~diagnostic_period (float, 1.0, s): read by diagnostic_updater.

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
import sys
import threading
import time

import diagnostic_updater
import rospy
import tf2_ros
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Quaternion, TransformStamped, Twist
from nav_msgs.msg import Odometry as OdometryMsg
from sensor_msgs.msg import Imu

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


def yaw_quaternion(yaw):
    return Quaternion(0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def diagonal(values):
    cov = [0.0] * 36
    for i, v in enumerate(values):
        cov[i * 7] = v
    return cov


class TurtlebotNode:
    def __init__(self):
        p = {name: rospy.get_param("~" + name, default) for name, default in (
            ("port", "/dev/ttyUSB0"), ("baud", 57600), ("operation_mode", oi.MODE_FULL), ("update_rate", 10.0),
            ("drive_mode", "twist"), ("cmd_vel_timeout", 0.6), ("stop_motors_on_bump", True), ("has_gyro", True),
            ("gyro_measurement_range", 150.0), ("gyro_scale_correction", 1.35),
            ("odom_angular_scale_correction", 1.0), ("odom_linear_scale_correction", 1.0), ("publish_tf", False),
            ("odom_frame", "odom"), ("base_frame", "base_footprint"), ("gyro_frame", "gyro_link"),
            ("reconnect_interval", 1.0), ("stall_timeout", 1.0))}
        problems = []
        if int(p["baud"]) not in oi.BAUD_CODES:
            problems.append(f"~baud {p['baud']} is not an OI baud rate {sorted(oi.BAUD_CODES)}")
        if p["operation_mode"] not in oi.MODE_OPCODES:
            problems.append(f"~operation_mode {p['operation_mode']} is not 1 (passive), 2 (safe) or 3 (full)")
        if p["drive_mode"] not in DRIVE_MODES:
            problems.append(f"~drive_mode {p['drive_mode']!r} is not one of {DRIVE_MODES}")
        for name in ("update_rate", "cmd_vel_timeout", "gyro_measurement_range", "gyro_scale_correction",
                     "odom_angular_scale_correction", "odom_linear_scale_correction", "reconnect_interval",
                     "stall_timeout"):
            if not float(p[name]) > 0.0:
                problems.append(f"~{name} must be > 0, got {p[name]}")
        if problems:
            for problem in problems:
                rospy.logfatal("turtlebot_node: %s", problem)
            sys.exit(1)
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
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(f"iRobot Create on {p['port']}")
        self.updater.add("Battery", self._diag_battery)
        self.updater.add("Open Interface", self._diag_mode)
        self.updater.add("Serial link", self._diag_serial)
        self._last_error_total = 0

        self.link = CreateLink(p["port"], int(p["baud"]), p["operation_mode"], self._on_frame,
                               reconnect_interval=p["reconnect_interval"], stall_timeout=p["stall_timeout"])
        rospy.Service("~set_operation_mode", SetTurtlebotMode, self._set_mode)
        rospy.Service("~set_digital_outputs", SetDigitalOutputs, self._set_outputs)
        rospy.Subscriber("cmd_vel", Twist, self._on_cmd_vel, queue_size=1)
        self.diag_timer = rospy.Timer(rospy.Duration(0.1), lambda _e: self.updater.update())
        rospy.on_shutdown(self.shutdown)
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
        odom.pose.pose.orientation = yaw_quaternion(pose.theta)
        odom.pose.covariance = diagonal(ODOM_POSE_COVARIANCE)
        odom.twist.twist.linear.x = pose.linear
        odom.twist.twist.angular.z = pose.angular
        odom.twist.covariance = diagonal(ODOM_TWIST_COVARIANCE)
        self.odom_pub.publish(odom)

        if self.tf_broadcaster is not None:
            tf = TransformStamped()
            tf.header.stamp = stamp
            tf.header.frame_id = self.p["odom_frame"]
            tf.child_frame_id = self.p["base_frame"]
            tf.transform.translation.x = pose.x
            tf.transform.translation.y = pose.y
            tf.transform.rotation = odom.pose.pose.orientation
            self.tf_broadcaster.sendTransform(tf)

        if self.imu_pub is not None and self.odometry.gyro_rate is not None:
            imu = Imu()
            imu.header.stamp = stamp
            imu.header.frame_id = self.p["gyro_frame"]
            imu.orientation = yaw_quaternion(self.odometry.gyro.orientation)
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
        self.diag_timer.shutdown()
        self.link.stop(safe_bytes=self._wheel_command(0.0, 0.0))


def main():
    rospy.init_node("turtlebot_node")
    TurtlebotNode()
    rospy.spin()
