"""Acceleration- and speed-limited velocity commands at a fixed rate (seed 3.6), ROS-free.

The filter keeps the last accepted command (the *desired* velocity) and, once per
publishing period, moves its output towards it by at most ``max_acc / publishing_rate``
per step: the seed's rule, applied to the forward speed (linear x) and the turn rate
(angular z) of the differential-drive base. Two additions make it the safety net in
front of the motors:

- absolute caps ``max_linear_vel`` / ``max_angular_vel`` clamp every desired value, so
  the output never exceeds them whatever arrives;
- commands with a NaN or infinite component are rejected (the previous command stays).

When the last accepted command is ``command_timeout`` or older (or none ever came), the
desired velocity is zero and the output ramps down at the acceleration limits.
"""

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Limits:
    """Parameters of the filter (names and defaults of seed Table 8, plus the speed caps)."""

    max_linear_acc: float = 1.0  # [m/s^2]
    max_angular_acc: float = 1.0  # [rad/s^2]
    publishing_rate: float = 50.0  # [Hz]
    command_timeout: float = 1.0  # [s]
    max_linear_vel: float = 0.5  # [m/s] the Create's top speed
    max_angular_vel: float = 2.0  # [rad/s]

    def problems(self):
        """Human-readable reasons why these limits are unusable (empty when fine)."""
        out = []
        for name in ("max_linear_acc", "max_angular_acc", "publishing_rate", "command_timeout",
                     "max_linear_vel", "max_angular_vel"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                out.append(f"{name} must be a finite number > 0, got {value!r}")
        return out


def step_towards(current, desired, max_step):
    """The seed's per-step rule: reach ``desired`` if it is within ``max_step``, else move by ``max_step``."""
    if desired - current > max_step:
        return current + max_step
    if current - desired > max_step:
        return current - max_step
    return desired


def clamp(value, limit):
    return max(-limit, min(limit, value))


class VelocityFilter:
    """Fixed-rate acceleration limiter with speed caps and a command timeout.

    Call :meth:`command` for every incoming velocity and :meth:`step` once per period
    (1 / ``publishing_rate``); ``now`` is any monotonic time in seconds (ROS time in the node).
    """

    def __init__(self, limits=None):
        self.limits = limits or Limits()
        problems = self.limits.problems()
        if problems:
            raise ValueError("; ".join(problems))
        self.linear = 0.0  # [m/s] last output
        self.angular = 0.0  # [rad/s] last output
        self._desired = (0.0, 0.0)  # [m/s, rad/s] last accepted command, capped
        self._stamp = None  # [s] when it arrived

    def command(self, linear, angular, now):
        """Take a new command; returns False (and keeps the previous one) if it is not finite."""
        if not (math.isfinite(linear) and math.isfinite(angular)):
            return False
        lim = self.limits
        self._desired = (clamp(linear, lim.max_linear_vel), clamp(angular, lim.max_angular_vel))
        self._stamp = now
        return True

    def timed_out(self, now):
        return self._stamp is None or now - self._stamp >= self.limits.command_timeout

    def step(self, now):
        """Advance one period; return the new output ``(linear [m/s], angular [rad/s])``."""
        lim = self.limits
        desired_lin, desired_ang = (0.0, 0.0) if self.timed_out(now) else self._desired
        lin = step_towards(self.linear, desired_lin, lim.max_linear_acc / lim.publishing_rate)
        ang = step_towards(self.angular, desired_ang, lim.max_angular_acc / lim.publishing_rate)
        self.linear = clamp(lin, lim.max_linear_vel)
        self.angular = clamp(ang, lim.max_angular_vel)
        return self.linear, self.angular
