"""The iRobot Create base: differential drive, bumpers, odometry and gyro (no ROS).

State vector of the true pose: (x [m], y [m], yaw [rad]) in the world (map)
frame; odometry (x, y, yaw) in the odom frame, which starts at zero where the
robot starts and then drifts with the configured wheel and gyro errors, as the
turtlebot_node odometry (wheels for distance, gyro for heading) does.
"""

import logging
import math
from dataclasses import dataclass

import numpy as np

from florence_common import pose
from florence_common.angles import wrap

log = logging.getLogger(__name__)

BUMP_RIGHT, BUMP_LEFT = 1, 2  # bits of TurtlebotSensorState.bumps_wheeldrops
PROBE_BEARINGS = np.radians([-75, -45, -20, 0, 20, 45, 75])  # bumper contact probes [rad]


@dataclass
class BaseConfig:
    """Create limits and sensor errors. Lengths [m], speeds [m/s], [rad/s], accelerations per s."""

    radius: float  # [m] footprint radius (Create body)
    height: float  # [m] top of the robot: obstacles below this height block it
    wheel_separation: float  # [m]
    max_wheel_speed: float = 0.5  # [m/s] Create Open Interface limit (500 mm/s per wheel)
    max_linear_acc: float = 1.0  # [m/s^2] (the Create ramps its wheel speeds; value assumed)
    max_angular_acc: float = 4.0  # [rad/s^2] (assumed)
    cmd_timeout: float = 0.6  # [s] no cmd_vel for this long stops the robot (turtlebot_node cmd_vel_timeout)
    odom_linear_scale_error: float = 0.01  # odometry distance = true * (1 + error)
    odom_linear_noise: float = 0.005  # [m/sqrt(m)] random walk of the odometry distance
    gyro_scale_error: float = 0.01  # measured rate = true * (1 + error)
    gyro_noise: float = 0.002  # [rad/sqrt(s)] random walk of the gyro heading
    gyro_bias: float = 0.0  # [rad/s] constant gyro drift
    contact_margin: float = 0.005  # [m] bumper switch travel: contact when this close

    def validate(self):
        for name in ("radius", "height", "wheel_separation", "max_wheel_speed", "max_linear_acc",
                     "max_angular_acc", "cmd_timeout"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        for name in ("odom_linear_noise", "gyro_noise", "contact_margin"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        for name in ("odom_linear_scale_error", "gyro_scale_error", "gyro_bias"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite")
        return self


def clamp_to_wheels(v, w, separation, max_wheel):
    """(v, w) after limiting the wheels to +-max_wheel [m/s] as turtlebot_node does
    (create_oi.twist_to_wheels): when a wheel would be faster, both are scaled down together, so
    the turning radius is kept and the robot drives the arc it was asked to, more slowly."""
    right = v + w * separation / 2
    left = v - w * separation / 2
    peak = max(abs(right), abs(left))
    if peak > max_wheel:
        right, left = right * max_wheel / peak, left * max_wheel / peak
    return (right + left) / 2, (right - left) / separation


class DiffDriveBase:
    """Create base in a scene. Call :meth:`command` with cmd_vel, :meth:`step` every physics tick."""

    def __init__(self, config, x=0.0, y=0.0, yaw=0.0, rng=None):
        self.cfg = config.validate()
        self.rng = rng or np.random.default_rng(0)
        self.set_pose(x, y, yaw, reset_odom=True)
        self.v = self.w = 0.0  # actual speeds [m/s], [rad/s]
        self.cmd_time = -math.inf  # [s] sim time of the last command
        self.bumps = 0
        self.in_contact = False
        self.collisions = 0  # contact events (rising edges)
        self.gyro_rate = 0.0  # [rad/s] measured
        self.distance_acc = 0.0  # [m] odometry distance since the last sensor packet
        self.angle_acc = 0.0  # [rad] odometry angle since the last sensor packet

    def set_pose(self, x, y, yaw, reset_odom=False):
        """Move the robot (a test service); odometry keeps counting unless reset."""
        self.x, self.y, self.yaw = float(x), float(y), float(yaw)
        if reset_odom:  # odometry starts at zero where the robot is, as the Create driver's does
            self.ox = self.oy = self.oyaw = 0.0
            self.odom_origin = (self.x, self.y, self.yaw)
            self.odom_v = self.odom_w = 0.0
        self.v = self.w = 0.0
        self.cmd_v = self.cmd_w = 0.0  # a carried robot forgets its last command

    def command(self, v, w, now):
        """Accept a velocity command at sim time ``now`` [s]; False (ignored) if not finite."""
        if not (math.isfinite(v) and math.isfinite(w)):
            return False
        self.cmd_v, self.cmd_w = clamp_to_wheels(v, w, self.cfg.wheel_separation, self.cfg.max_wheel_speed)
        self.cmd_time = now
        return True

    def step(self, dt, now, scene):
        """Advance by ``dt`` [s] at sim time ``now`` in ``scene`` (a geometry.Scene)."""
        cfg = self.cfg
        stale = now - self.cmd_time > cfg.cmd_timeout
        target_v, target_w = (0.0, 0.0) if stale else (self.cmd_v, self.cmd_w)
        self.v += max(-cfg.max_linear_acc * dt, min(cfg.max_linear_acc * dt, target_v - self.v))
        self.w += max(-cfg.max_angular_acc * dt, min(cfg.max_angular_acc * dt, target_w - self.w))

        # exact integration of an arc
        dyaw = self.w * dt
        ds = self.v * dt
        heading = self.yaw + dyaw / 2
        nx, ny = self.x + ds * math.cos(heading), self.y + ds * math.sin(heading)
        # one clearance query: centre now and after the move, and the bumper probes at both
        r = self.cfg.radius + self.cfg.contact_margin
        angles = self.yaw + dyaw + PROBE_BEARINGS
        ring = np.stack([r * np.cos(angles), r * np.sin(angles)], axis=1)
        here, there = np.array([self.x, self.y]), np.array([nx, ny])
        points = np.concatenate([[here, there], ring + here, ring + there])
        dist, _ = scene.clearance(points, z_max=cfg.height, z_min=0.0)
        before, after = dist[0] - cfg.radius, dist[1] - cfg.radius
        probes = dist[2 + len(ring):]
        moved = ds
        if after < 0 and after < before:  # would push into an obstacle: the bumper stops the robot
            nx, ny = self.x, self.y
            probes = dist[2:2 + len(ring)]
            moved = 0.0
            self.v = 0.0
            self.w = 0.0
            dyaw = 0.0
        self.x, self.y = nx, ny
        self.yaw = wrap(self.yaw + dyaw)
        self._update_bumpers(probes <= 0)
        self._odometry(dt, moved, dyaw)

    def _update_bumpers(self, hit):
        """Bumper bits from which probes (at PROBE_BEARINGS) touch an obstacle."""
        bumps = 0
        if hit[PROBE_BEARINGS <= 0].any():
            bumps |= BUMP_RIGHT
        if hit[PROBE_BEARINGS >= 0].any():
            bumps |= BUMP_LEFT
        contact = bumps != 0
        if contact and not self.in_contact:
            self.collisions += 1
        self.in_contact = contact
        self.bumps = bumps

    def _odometry(self, dt, moved, dyaw):
        cfg = self.cfg
        ds = moved * (1 + cfg.odom_linear_scale_error)
        if cfg.odom_linear_noise and moved:
            ds += self.rng.normal(0.0, cfg.odom_linear_noise * math.sqrt(abs(moved)))
        rate = dyaw / dt * (1 + cfg.gyro_scale_error) + cfg.gyro_bias
        if cfg.gyro_noise:
            rate += self.rng.normal(0.0, cfg.gyro_noise / math.sqrt(dt))
        self.gyro_rate = rate
        dth = rate * dt
        heading = self.oyaw + dth / 2
        self.ox += ds * math.cos(heading)
        self.oy += ds * math.sin(heading)
        self.oyaw = wrap(self.oyaw + dth)
        self.odom_v, self.odom_w = ds / dt, rate
        self.distance_acc += ds
        self.angle_acc += dth

    def odom_in_world(self):
        """The odometry pose (x, y, yaw) expressed in the world, through the pose it started at."""
        return pose.compose(self.odom_origin, (self.ox, self.oy, self.oyaw))

    def take_packet_deltas(self):
        """(distance [m], angle [rad]) since the previous call, like the Create's sensor packet."""
        out = (self.distance_acc, self.angle_acc)
        self.distance_acc = self.angle_acc = 0.0
        return out
