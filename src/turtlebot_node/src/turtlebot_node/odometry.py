"""Odometry of the Create with the TurtleBot's gyro: ROS-free, one stream frame at a time.

Formulas (those of the original ROS turtlebot_node, gyro.py and turtlebot_node.py):

- Gyro zero (``cal_offset``): the mean of the last 1000 analog readings taken
  while the robot stands still (original: requested right and left velocity 0
  and distance 0; here also angle 0 and Drive velocity 0).
- Gyro rate [rad/s], counter-clockwise positive::

      rate = -(raw - cal_offset) / cal_offset * gyro_measurement_range * pi/180 * gyro_scale_correction

  i.e. the analog input swings from 0 to 2 * cal_offset over
  +-gyro_measurement_range [deg/s]; the sign flips because the TurtleBot's
  ADXRS613 voltage falls when turning counter-clockwise.
- Encoder increments: ``d = distance * odom_linear_scale_correction`` and
  ``dtheta = angle * odom_angular_scale_correction`` (distance [m], angle [rad]).

The original fused gyro and encoders in robot_pose_ekf, which Debian lacks;
here, as seed Table 5 says ("odometry based on the gyro and sensor_state"),
the heading integrates the gyro rate when ``has_gyro`` is set and the zero is
known, the encoder angle otherwise. Position integrates ``d`` along the
mid-step heading. Time steps are the device's stream period (15 ms per frame),
not the host's receive times, which bunch up behind USB and scheduler latency.
"""

import math
from collections import deque
from dataclasses import dataclass

GYRO_CALIBRATION_SAMPLES = 1000  # readings averaged for the zero (original cal_buffer_length)
MAX_FRAME_DISTANCE = 1.0  # [m] larger increments are junk (the original's plausibility check)
MAX_FRAME_ANGLE = 1.0  # [rad]
# The robot stands still (gyro zero may be sampled) when all of these are 0. The original looked at
# the requested wheel velocities and the distance; the angle and the Drive velocity are added so a
# turn on the spot commanded with Drive (137) cannot pollute the zero.
STATIONARY_KEYS = ("requested_right_velocity", "requested_left_velocity", "requested_velocity", "distance", "angle")


@dataclass
class Pose2D:
    x: float = 0.0  # [m]
    y: float = 0.0  # [m]
    theta: float = 0.0  # [rad], unwrapped
    linear: float = 0.0  # [m/s]
    angular: float = 0.0  # [rad/s]


class Gyro:
    """Zero estimate and rate of the analog gyro on the Create's cargo-bay input."""

    def __init__(self, measurement_range=150.0, scale_correction=1.35, samples=GYRO_CALIBRATION_SAMPLES):
        self.measurement_range = measurement_range  # [deg/s] full scale of the gyro
        self.scale_correction = scale_correction
        self.readings = deque(maxlen=samples)
        self.offset = None  # [counts] zero-rate reading, None until the robot stood still
        self.orientation = 0.0  # [rad] integrated rate

    def update_calibration(self, raw, stationary):
        if stationary:
            self.readings.append(raw)
            self.offset = sum(self.readings) / len(self.readings)

    def rate(self, raw):
        """Angular rate [rad/s] for analog reading ``raw``; None before calibration."""
        if not self.offset:
            return None
        return -(raw - self.offset) / self.offset * self.measurement_range * math.pi / 180.0 * self.scale_correction


class Odometry:
    """Integrates stream frames (dicts of raw sensor values) into a planar pose."""

    def __init__(self, gyro=None, linear_scale=1.0, angular_scale=1.0, period=0.015):
        self.gyro = gyro  # Gyro or None (has_gyro false)
        self.linear_scale = linear_scale
        self.angular_scale = angular_scale
        self.period = period  # [s] device time per frame
        self.pose = Pose2D()
        self.rejected = 0  # frames with implausible increments
        self.gyro_rate = None  # [rad/s] last gyro rate, None without gyro or zero

    def update(self, frame):
        """Add one frame; returns False (and counts it) when its increments are junk."""
        distance = frame["distance"] / 1000.0 * self.linear_scale  # [m]
        angle = math.radians(frame["angle"]) * self.angular_scale  # [rad]
        if abs(distance) > MAX_FRAME_DISTANCE or abs(angle) > MAX_FRAME_ANGLE:
            self.rejected += 1
            return False
        dtheta = angle
        self.gyro_rate = None
        if self.gyro is not None:
            stationary = all(frame[key] == 0 for key in STATIONARY_KEYS)
            self.gyro.update_calibration(frame["user_analog_input"], stationary)
            rate = self.gyro.rate(frame["user_analog_input"])
            if rate is not None:
                self.gyro_rate = rate
                self.gyro.orientation += rate * self.period
                dtheta = rate * self.period
        pose = self.pose
        mid = pose.theta + dtheta / 2.0
        pose.x += distance * math.cos(mid)
        pose.y += distance * math.sin(mid)
        pose.theta += dtheta
        pose.linear = distance / self.period
        pose.angular = dtheta / self.period
        return True
