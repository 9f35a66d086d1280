"""The robot footprint: a polygon in the base frame (ROS-free, costmap_2d's footprint rules).

A footprint is an (N, 2) array of vertices [m] in the robot base frame (x forward, y left),
in order around the polygon. ROS reads it from the ``footprint`` parameter, or builds a
circle from ``robot_radius`` when there is none.
"""

import math

import numpy as np

from florence_common import pose


def footprint_value(value):
    """The ``footprint`` parameter as a list of [x, y] points, or None when it is empty: ROS takes
    the list or its string form "[[x, y], ...]". Raises ValueError for a string that is not YAML."""
    if isinstance(value, str):
        text = value.strip()
        if text in ("", "[]"):
            return None
        import yaml

        try:
            return yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ValueError(f"footprint {text!r} is not a list of [x, y] points: {exc}") from None
    return value or None


def parse_footprint(value, robot_radius=0.46):
    """Footprint from the ``footprint`` parameter (a list of [x, y] pairs or its string form
    "[[x, y], ...]"), or a 16-gon of ``robot_radius`` [m] when ``value`` is empty.

    Raises ValueError naming the problem for a malformed footprint.
    """
    value = footprint_value(value)
    if not value:
        if not robot_radius > 0.0:
            raise ValueError(f"robot_radius must be positive, got {robot_radius}")
        angles = np.arange(16) * (2.0 * math.pi / 16)
        return np.column_stack([robot_radius * np.cos(angles), robot_radius * np.sin(angles)])
    try:
        points = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"footprint {value!r} is not a list of [x, y] points") from None
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"footprint {value!r} is not a list of [x, y] points")
    if len(points) < 3:
        raise ValueError(f"footprint needs at least 3 points, got {len(points)}")
    if not np.all(np.isfinite(points)):
        raise ValueError(f"footprint {value!r} has a non-finite coordinate")
    return points


def pad_footprint(points, padding):
    """Footprint grown by ``padding`` [m] away from the origin in x and y, as costmap_2d's
    padFootprint does (each coordinate moves by ``padding`` along its sign)."""
    points = np.asarray(points, dtype=float)
    return points + np.sign(points) * float(padding)


def _distance_to_segments(points):
    """Distance [m] from the origin to each edge of the closed polygon ``points``."""
    a = points
    b = np.roll(points, -1, axis=0)
    ab = b - a
    length2 = np.einsum("ij,ij->i", ab, ab)
    t = np.where(length2 > 0.0, np.clip(-np.einsum("ij,ij->i", a, ab) / np.where(length2 > 0, length2, 1.0), 0, 1), 0)
    closest = a + t[:, None] * ab
    return np.hypot(closest[:, 0], closest[:, 1])


def inscribed_radius(points):
    """Radius [m] of the largest circle about the origin inside the footprint: the distance to
    the nearest edge (costmap_2d's calculateMinAndMaxDistances)."""
    points = np.asarray(points, dtype=float)
    return float(min(_distance_to_segments(points).min(), np.hypot(points[:, 0], points[:, 1]).min()))


def circumscribed_radius(points):
    """Radius [m] of the smallest circle about the origin holding the footprint: the farthest vertex."""
    points = np.asarray(points, dtype=float)
    return float(np.hypot(points[:, 0], points[:, 1]).max())


def transform_footprint(points, x, y, yaw):
    """The footprint's vertices (N, 2) in the world frame for a robot at (x, y) [m] heading ``yaw`` [rad]."""
    return pose.transform_points((x, y, yaw), points)
