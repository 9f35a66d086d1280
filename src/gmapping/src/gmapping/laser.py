"""The laser as slam_gmapping uses it, without ROS: where its beams go on the robot, and which
readings count.

The geometry comes from the laser's real pose on the robot (tf), beam by beam
(:func:`florence_common.pose.beams_in_plane`): a laser mounted upside down, like the Florence
Hokuyo, gets mirrored bearings and nothing else changes. The original slam_gmapping reached the
same end by a "centred" laser frame rolled by pi and a reversed range order; there is no patched
copy and no flag here.
"""

from dataclasses import dataclass

import numpy as np

from florence_common.pose import beams_in_plane

PLANAR_TOLERANCE = 0.001  # the laser's z axis must be within this of the base's (slam_gmapping's check)


class LaserNotPlanar(ValueError):
    """The laser's scan plane is not parallel to the robot's floor plane."""


@dataclass(frozen=True)
class LaserGeometry:
    """One laser's beams in the robot's base frame."""

    x: float  # [m] laser origin in the base frame
    y: float  # [m]
    cos: np.ndarray  # [B] beam direction cosines in the base frame
    sin: np.ndarray  # [B] beam direction sines in the base frame
    upside_down: bool

    @classmethod
    def from_transform(cls, laser_in_base, angle_min, angle_increment, count):
        """The geometry of a LaserScan's ``count`` beams (``angle_min`` + i ``angle_increment`` [rad]) for a
        laser at ``laser_in_base`` (4x4 pose of the laser frame in the base frame). Raises LaserNotPlanar
        when the scan plane is tilted against the floor."""
        angles = angle_min + angle_increment * np.arange(int(count))
        xy, bearings, up = beams_in_plane(laser_in_base, angles)
        if abs(abs(up) - 1.0) > PLANAR_TOLERANCE:
            raise LaserNotPlanar(f"the laser has to be mounted planar: its z axis has {up:.4f} along the base's "
                                 "z axis, not 1 or -1")
        return cls(float(xy[0]), float(xy[1]), np.cos(bearings), np.sin(bearings), up < 0)

    @property
    def bearings(self):
        """[B] beam directions in the base frame [rad]."""
        return np.arctan2(self.sin, self.cos)


def usable_ranges(ranges, range_min, max_range):
    """Readings [m] as the mapper takes them (float64): NaN, +-inf, readings below ``range_min`` or beyond
    ``max_range`` become +inf, "no reading": neither a hit nor free space. (The original turns readings
    below range_min into range_max; no-return readings are +inf on our lasers, REP 117.)"""
    r = np.asarray(ranges, dtype=float)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r >= range_min) & (r > 0.0) & (r <= max_range)
    return np.where(ok, r, np.inf)
