"""Recovery behaviours of move_base (ROS-free), stepped by the control cycle.

Each behaviour has ``name``, ``start(now, pose)`` and ``step(now, pose) -> (done, cmd)`` where
``cmd`` is (vx [m/s], vy [m/s], vth [rad/s]) or None. Stepping (instead of ROS's blocking loop)
lets a cancel or a new goal stop a recovery between two cycles.

ROS's default list (move_base.cpp loadDefaultRecoveryBehaviors), built by
:func:`default_recovery_specs`: conservative_reset (clear obstacles farther than
conservative_reset_dist), rotate_recovery (if clearing_rotation_allowed), aggressive_reset (clear
farther than 4 x the circumscribed radius), rotate_recovery again.
"""

import logging
import math

import numpy as np

from florence_common import angles
from florence_common.params import Param, ParamTable
from move_base.footprint import transform_footprint

log = logging.getLogger(__name__)

CLEAR_COSTMAP_PARAMS = ParamTable(
    Param("reset_distance", float, 3.0, "side of the square round the robot whose obstacles are kept", unit="m",
          ge=0.0),
)
"""A ClearCostmapRecovery's parameters (``~<name>/``, as ROS's clear_costmap_recovery)."""


class ClearCostmapRecovery:
    """Reset the obstacle layers of the costmaps outside a square of side ``reset_distance`` [m]
    centred on the robot (ROS clear_costmap_recovery/ClearCostmapRecovery). Each costmap offers
    ``get_robot_pose()`` and ``clear_outside(x, y, size)``."""

    def __init__(self, name, costmaps, reset_distance):
        if not reset_distance >= 0.0:
            raise ValueError(f"{name}: reset_distance must be >= 0, got {reset_distance}")
        self.name = name
        self.costmaps = list(costmaps)
        self.reset_distance = float(reset_distance)
        self.outcome = ""  # how the last run ended, in words (the node logs it)

    def start(self, now, pose):
        pass

    def step(self, now, pose):
        for costmap in self.costmaps:
            # each costmap is in its own frame: the window goes round the robot's pose in it
            here = costmap.get_robot_pose()
            if here is not None:
                costmap.clear_outside(here[0], here[1], self.reset_distance)
        self.outcome = f"cleared obstacles farther than {self.reset_distance / 2.0:.2f} m"
        log.info("%s: %s", self.name, self.outcome)
        return True, None


class RotateRecovery:
    """Turn once in place (2 pi) to see around, stopping early if the turn would collide
    (ROS rotate_recovery/RotateRecovery).

    ``costmap_check(x, y, yaw) -> cost`` gives the footprint cost in the local costmap (< 0: a
    collision); ``pose_in_local()`` the robot's pose in the local costmap's frame. Speeds follow
    the local planner's limits: sqrt(2 acc_lim_th * remaining) capped to max_rotational_vel and
    at least min_in_place_rotational_vel [rad/s].
    """

    def __init__(self, name, costmap_check, pose_in_local, acc_lim_th=3.2, max_rotational_vel=1.0,
                 min_in_place_rotational_vel=0.4, sim_granularity=0.017, tolerance=0.10, timeout=60.0):
        self.name = name
        self.costmap_check = costmap_check
        self.pose_in_local = pose_in_local
        self.acc_lim_th = float(acc_lim_th)
        self.max_vel = float(max_rotational_vel)
        self.min_vel = float(min_in_place_rotational_vel)
        self.sim_granularity = float(sim_granularity)
        self.tolerance = float(tolerance)
        self.timeout = float(timeout)
        self._turned = 0.0
        self._last_yaw = None
        self._started = 0.0
        self.outcome = ""  # how the last run ended, in words (the node logs it)

    def start(self, now, pose):
        self._turned = 0.0
        self._last_yaw = None
        self._started = now

    def step(self, now, pose):
        local = self.pose_in_local()
        if local is None:
            return self._end("no robot pose in the local costmap, stopping")
        x, y, yaw = local
        if self._last_yaw is not None:
            self._turned += abs(angles.diff(yaw, self._last_yaw))
        self._last_yaw = yaw
        remaining = 2.0 * math.pi - self._turned
        if remaining <= self.tolerance:
            return self._end(f"turned {self._turned:.2f} rad", warn=False)
        if now - self._started > self.timeout:
            return self._end(f"timed out after {now - self._started:.1f} s, turned {self._turned:.2f} rad")
        # check the rest of the turn for collisions, in steps of sim_granularity [rad]
        steps = np.arange(self.sim_granularity, remaining + 1e-9, self.sim_granularity)
        for a in steps:
            if self.costmap_check(x, y, yaw + a) < 0.0:
                return self._end(f"rotation in collision {a:.2f} rad ahead after {self._turned:.2f} rad, stopping")
        vel = min(self.max_vel, max(self.min_vel, math.sqrt(2.0 * self.acc_lim_th * remaining)))
        return False, (0.0, 0.0, vel)

    def _end(self, outcome, warn=True):
        self.outcome = outcome
        (log.warning if warn else log.info)("%s: %s", self.name, outcome)
        return True, (0.0, 0.0, 0.0)


def default_recovery_specs(conservative_reset_dist, circumscribed_radius, clearing_rotation_allowed):
    """ROS's default recovery list as (name, type, reset_distance or None)."""
    specs = [("conservative_reset", "clear_costmap_recovery/ClearCostmapRecovery", conservative_reset_dist)]
    if clearing_rotation_allowed:
        specs.append(("rotate_recovery", "rotate_recovery/RotateRecovery", None))
    specs.append(("aggressive_reset", "clear_costmap_recovery/ClearCostmapRecovery", 4.0 * circumscribed_radius))
    if clearing_rotation_allowed:
        specs.append(("rotate_recovery", "rotate_recovery/RotateRecovery", None))
    return specs


def footprint_collision_check(footprint_cost, footprint):
    """A ``costmap_check(x, y, yaw)`` for :class:`RotateRecovery` from a ``footprint_cost(points)``."""

    def check(x, y, yaw):
        return footprint_cost(transform_footprint(footprint, x, y, yaw))

    return check
