"""calibrate.py: gyro and odometry scale calibration against a wall (user manual 7.2).

Runs :class:`turtlebot_calibration.calibration.Calibrator` on the robot (or florence_sim), prints
the seed's two lines ("Multiply the 'turtlebot_node/gyro_scale_correction' parameter with X", the
same for odom_angular_scale_correction) and exits: status 0 when it printed them, 1 with the reason
when it could not calibrate (no scan, no wall in front, no gyro or odometry, interrupted). The
robot is stopped whenever it exits.

ROS Parameters: PARAMS below (rendered in the README); also read: ``turtlebot_node/has_gyro``
(bool, true: calibrate the gyro), ``turtlebot_node/odom_angular_scale_correction`` (float, 1.0: the
factor turtlebot_node applies to the Create's angle, applied here to the raw angle of
~sensor_state), ``turtlebot_node/gyro_scale_correction`` (only to print the value to set).

ROS Subscribers:
    scan (sensor_msgs/LaserScan): the wall; any laser (the launch remaps it to the Kinect's narrow
        fake laser ``scan_angle``), any mounting: every beam goes through tf into ~base_frame.
    imu (sensor_msgs/Imu): the gyro's heading (orientation yaw); remapped to imu/data.
    turtlebot_node/sensor_state (turtlebot_node/TurtlebotSensorState): the Create's wheel angle
        increments (``angle`` [rad], raw), the odometry whose scale odom_angular_scale_correction sets.
        (turtlebot_node's ``odom`` heading is the gyro's when there is one, so it is not used.)

ROS Publishers:
    cmd_vel (geometry_msgs/Twist): turns on the spot (angular.z only); zero when done.
"""

import math
import sys
import threading
import time

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Twist
from sensor_msgs.msg import Imu, LaserScan

from florence_common.angles import diff
from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.convert import yaw_of
from florence_common_ros.node import build, publish_stop, read_params
from florence_common_ros.transforms import lookup_matrix
from turtlebot_calibration.calibration import (
    GYRO_PARAM,
    ODOM_PARAM,
    CalibrationConfig,
    CalibrationError,
    Calibrator,
    GapCounter,
    Interrupted,
    Robot,
    result_lines,
)
from turtlebot_calibration.wall import WallConfig, scan_points
from turtlebot_node.msg import TurtlebotSensorState

LOG = "turtlebot_calibration: "
DEFAULTS = CalibrationConfig()
WALL = WallConfig()


def _speeds(value):
    if not value or not all(isinstance(v, (int, float)) and math.isfinite(v) and 0 < v <= 4.0 for v in value):
        return "must be a list of turn rates within (0, 4] rad/s"
    return None


PARAMS = ParamTable(
    Param("speeds", list, list(DEFAULTS.speeds), "turn rates of the full turns, one turn each (the original's)",
          unit="rad/s", check=_speeds),
    Param("imu_calibrate_time", float, DEFAULTS.drift_time, "standing still to measure the gyro's drift "
          "(original name)", unit="s", gt=0),
    Param("inital_wall_angle", float, DEFAULTS.align_tolerance, "a turn starts only this close to facing the "
          "wall (the original's name, spelling included)", unit="rad", gt=0, lt=0.5),
    Param("base_frame", FRAME, "base_footprint", "the robot's frame: the wall is fitted there"),
    Param("max_bearing", float, WALL.max_bearing, "beams within this bearing of straight ahead (base frame) "
          "may be the wall", unit="rad", gt=0, le=1.5),
    Param("max_range", float, WALL.max_range, "farther readings are not the wall", unit="m", gt=0),
    Param("scan_samples", int, DEFAULTS.scan_samples, "scans averaged for one heading at rest", ge=1),
    Param("input_timeout", float, 15.0, "time to wait at start-up for the first scan, gyro and odometry messages "
          "(ROS time: simulated seconds once /clock runs; a silent /clock is given 4 times this in wall time)",
          unit="s", gt=0),
    Param("scan_timeout", float, DEFAULTS.scan_timeout, "no scan for this long during the calibration ends "
          "it", unit="s", gt=0),
    Param("wall_timeout", float, DEFAULTS.wall_timeout, "the wall may be hidden (someone passing) this long",
          unit="s", gt=0),
)


class RosRobot(Robot):
    """The calibration's Robot over ROS: latest gyro and wheel headings (unwrapped), scans as
    points in the base frame, turn commands on cmd_vel."""

    def __init__(self, base_frame, odom_correction):
        self.base_frame = base_frame
        self.odom_correction = odom_correction  # turtlebot_node's current factor on the raw angle
        self.cond = threading.Condition()
        self.scan = None  # latest LaserScan
        self.scan_count = 0
        self.taken = 0  # scan_count of the last scan handed out
        self.gyro_heading = None  # [rad] unwrapped
        self.gyro_last = None  # [rad] last yaw
        self.wheel_heading = None  # [rad] raw sum of ~sensor_state angles
        self.state_gaps = GapCounter()  # ~sensor_state messages missing
        self.imu_stamp = self.state_stamp = None  # [s] of the last message of each
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.subs = [
            rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=2),
            rospy.Subscriber("imu", Imu, self._on_imu, queue_size=200),
            # angle increments: a dropped message is a lost angle, so a long queue (10 Hz on the robot;
            # a simulator faster than real time on a busy machine must not overflow it)
            rospy.Subscriber("turtlebot_node/sensor_state", TurtlebotSensorState, self._on_state, queue_size=1000),
        ]

    # --- callbacks -----------------------------------------------------------------------------
    def _on_scan(self, msg):
        with self.cond:
            self.scan = msg
            self.scan_count += 1
            self.cond.notify_all()

    def _on_imu(self, msg):
        try:
            yaw = yaw_of(msg.orientation)
        except ValueError:
            rospy.logwarn_throttle(5.0, LOG + "imu message with a zero orientation quaternion skipped")
            return
        if not math.isfinite(yaw):
            rospy.logwarn_throttle(5.0, LOG + "imu message with a non-finite orientation skipped")
            return
        with self.cond:
            if self.gyro_heading is None:
                self.gyro_heading = 0.0
            else:
                self.gyro_heading += diff(yaw, self.gyro_last)
            self.gyro_last = yaw
            self.imu_stamp = msg.header.stamp.to_sec() or rospy.get_time()  # unstamped: as received
            self.cond.notify_all()

    def _on_state(self, msg):
        if not math.isfinite(msg.angle):
            rospy.logwarn_throttle(5.0, LOG + "sensor_state with a non-finite angle skipped")
            return
        stamp = msg.header.stamp.to_sec() or rospy.get_time()  # unstamped: as received
        with self.cond:
            self.wheel_heading = (self.wheel_heading or 0.0) + msg.angle
            # each message carries the angle since the one before: count the ones a busy publisher or
            # subscriber dropped (the turn's odometry is then not used)
            self.state_gaps.add(stamp)
            self.state_stamp = stamp
            self.cond.notify_all()

    # --- Robot ---------------------------------------------------------------------------------
    def now(self):
        return rospy.get_time()

    def sleep(self, seconds):
        try:
            rospy.sleep(seconds)
        except rospy.ROSInterruptException as exc:
            raise Interrupted(str(exc)) from None
        if rospy.is_shutdown():
            raise Interrupted("shutting down")

    def command(self, angular):
        msg = Twist()
        msg.angular.z = float(angular)
        try:
            self.pub.publish(msg)
        except rospy.ROSException as exc:  # shutting down
            raise Interrupted(str(exc)) from None

    def next_scan(self, timeout):
        """The next scan's points in the base frame; waits ``timeout`` [s] of ROS time (and at most
        5 x that of wall time, should the clock stop)."""
        deadline = rospy.get_time() + timeout
        wall_deadline = time.monotonic() + max(5.0 * timeout, 10.0)
        reason = f"no message on {rospy.resolve_name('scan')}"
        while True:
            with self.cond:
                self.cond.wait_for(lambda: self.scan_count > self.taken or rospy.is_shutdown(), 0.05)
                msg, fresh = self.scan, self.scan_count > self.taken
                self.taken = self.scan_count
            if rospy.is_shutdown():
                raise Interrupted("shutting down")
            if fresh:
                points, why = self.points(msg)
                if points is not None:
                    return msg.header.stamp.to_sec(), points
                reason = f"scans arrive but {why}"
            if rospy.get_time() >= deadline or time.monotonic() >= wall_deadline:
                return None, reason

    def points(self, msg):
        """(points [N, 2] in the base frame, None) of a LaserScan, or (None, why)."""
        frame = msg.header.frame_id.lstrip("/")
        if not frame:
            return None, "the scan has no frame_id"
        matrix, why = lookup_matrix(self.tf_buffer, self.base_frame, frame, rospy.Time(0), timeout=0.2)
        if matrix is None:
            return None, why
        return scan_points(np.asarray(msg.ranges, dtype=float), msg.angle_min, msg.angle_increment, msg.range_min,
                           msg.range_max, matrix), None

    def gyro(self):
        with self.cond:
            return self.gyro_heading

    def odom(self):
        with self.cond:
            return None if self.wheel_heading is None else self.wheel_heading * self.odom_correction

    def sync(self, t, timeout):
        """Wait until the gyro's and ~sensor_state's latest stamps reach ``t`` (their callbacks caught
        up with the clock), ``timeout`` [s] of ROS time at most (and 5 x that of wall time)."""
        deadline = rospy.get_time() + timeout
        wall_deadline = time.monotonic() + max(5.0 * timeout, 10.0)

        def behind():
            late = []
            if self.gyro_heading is not None and self.imu_stamp < t:
                late.append(f"no gyro message on {rospy.resolve_name('imu')} for "
                            f"{rospy.get_time() - self.imu_stamp:.1f} s")
            if self.wheel_heading is not None and self.state_stamp < t:
                late.append(f"no odometry on {rospy.resolve_name('turtlebot_node/sensor_state')} for "
                            f"{rospy.get_time() - self.state_stamp:.1f} s")
            return late

        with self.cond:
            while late := behind():
                if rospy.is_shutdown():
                    raise Interrupted("shutting down")
                if rospy.get_time() >= deadline or time.monotonic() >= wall_deadline:
                    return " and ".join(late) + ": is turtlebot_node (or the simulator) still running?"
                self.cond.wait(0.05)
        return None

    def odom_lost(self):
        with self.cond:
            return self.state_gaps.lost

    def stop(self):
        publish_stop(self.pub, wait=0.1)


class CalibrationNode:
    def __init__(self):
        p = read_params(PARAMS)
        self.p = p
        self.has_gyro = bool(rospy.get_param("turtlebot_node/has_gyro", True))
        self.odom_correction = float(rospy.get_param(ODOM_PARAM, 1.0))
        if not (math.isfinite(self.odom_correction) and self.odom_correction > 0):
            raise ValueError(f"{ODOM_PARAM} must be a number > 0, got {self.odom_correction!r}")
        wall = WallConfig(max_bearing=p.max_bearing, max_range=p.max_range)
        self.config = CalibrationConfig(speeds=tuple(float(s) for s in p.speeds), drift_time=p.imu_calibrate_time,
                                        align_tolerance=p.inital_wall_angle, scan_samples=p.scan_samples,
                                        scan_timeout=p.scan_timeout, wall_timeout=p.wall_timeout,
                                        wall=wall).validate()
        self.robot = RosRobot(p.base_frame, self.odom_correction)

    def shutdown(self):
        self.robot.stop()

    def _wait_for_clock(self, timeout):
        """Under simulated time, wait (wall time) for the first /clock."""
        if not rospy.get_param("/use_sim_time", False):
            return
        deadline = time.monotonic() + timeout
        while rospy.get_time() <= 0.0:
            if rospy.is_shutdown():
                raise Interrupted("shutting down")
            if time.monotonic() >= deadline:
                raise CalibrationError(f"no /clock in {timeout:.0f} s although /use_sim_time is set: is the "
                                       "simulator running?")
            time.sleep(0.05)

    def _wait_for_inputs(self):
        """Wait for a scan, the odometry and, with a gyro, the gyro (input_timeout of ROS time once the
        clock runs); raise CalibrationError naming what did not come."""
        robot, timeout = self.robot, self.p.input_timeout
        self._wait_for_clock(4.0 * timeout)
        wanted = {
            "scan": (lambda: robot.scan is not None,
                     f"no scan on {rospy.resolve_name('scan')}: is the laser, or the Kinect's fake laser "
                     f"(minimal_calibration.launch), running?"),
            "odometry": (lambda: robot.wheel_heading is not None,
                         f"no odometry on {rospy.resolve_name('turtlebot_node/sensor_state')}: is turtlebot_node "
                         f"(minimal_calibration.launch) running and the Create switched on?"),
        }
        if self.has_gyro:
            wanted["gyro"] = (lambda: robot.gyro_heading is not None,
                              f"no gyro on {rospy.resolve_name('imu')} although turtlebot_node/has_gyro is true: is "
                              f"the gyro connected? Set turtlebot_node/has_gyro false to calibrate the odometry only.")
        rospy.loginfo(LOG + "waiting for %s", ", ".join(wanted))
        deadline = rospy.get_time() + timeout
        wall_deadline = time.monotonic() + 4.0 * timeout  # should the clock stop
        while not rospy.is_shutdown():
            with robot.cond:
                missing = [why for ready, why in wanted.values() if not ready()]
            if not missing:
                return
            if rospy.get_time() >= deadline or time.monotonic() >= wall_deadline:
                raise CalibrationError(f"nothing came in {timeout:.0f} s: " + " ".join(missing))
            time.sleep(0.05)
        raise Interrupted("shutting down")

    def run(self):
        """The whole calibration; returns the exit status."""
        try:
            self._wait_for_inputs()
            if not self.has_gyro:
                rospy.logwarn(LOG + "turtlebot_node/has_gyro is false: calibrating the odometry only")
            calibrator = Calibrator(self.robot, self.config, report=rospy.loginfo,
                                    warn=lambda text: rospy.logwarn(LOG + text))
            result = calibrator.run()
        except CalibrationError as exc:
            rospy.logerr(LOG + "cannot calibrate: %s", exc)
            self.robot.stop()
            return 1
        except Interrupted:
            rospy.logwarn(LOG + "interrupted: no result")
            self.robot.stop()
            return 1
        self.robot.stop()
        for line in result_lines(result):
            rospy.loginfo(line)
        for name, value in ((GYRO_PARAM, result.gyro_factor), (ODOM_PARAM, result.odom_factor)):
            current = rospy.get_param(name, None)
            if value is not None and isinstance(current, (int, float)):
                rospy.loginfo(f"({name} is {current:f} now: set it to {current * value:f} in "
                              "turtlebot_control/config/gyro_yourcompany.launch and calibrate again until the "
                              "factors stay near 1.00)")
        return 0


def main():
    rospy.init_node("turtlebot_calibration")
    node = build(CalibrationNode, "turtlebot_calibration")
    sys.exit(node.run())
