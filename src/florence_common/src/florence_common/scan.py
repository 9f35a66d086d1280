"""Laser scans as points (sensor_msgs/LaserScan's fields, no message class).

A scan's beam ``i`` points at ``angle_min + i * angle_increment`` [rad] in the scan's frame; a
*return* is a finite range inside ``(range_min, range_max)``. +inf is no echo (REP 117: the beam
ran free to range_max), NaN an error (nothing known along the beam). An upside-down sensor needs
no special case: its frame's pose (rolled by pi) turns the points right.
"""

import numpy as np


def beam_angles(count, angle_min, angle_increment):
    """Angle [rad] of each of ``count`` beams."""
    return float(angle_min) + float(angle_increment) * np.arange(int(count))


def returns(ranges, range_min, range_max):
    """Boolean mask of the beams with a return."""
    r = np.asarray(ranges, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.isfinite(r) & (r > range_min) & (r < range_max)


def scan_points(ranges, angle_min, angle_increment, range_min, range_max, pose=None):
    """(points [N, 3], beams [N]) of a scan's returns: in the scan's frame, or, with ``pose`` (the 4x4
    pose of the scan's frame in another frame), in that frame; ``beams`` are their indices."""
    r = np.asarray(ranges, dtype=float)
    beams = np.flatnonzero(returns(r, range_min, range_max))
    a = beam_angles(len(r), angle_min, angle_increment)[beams]
    local = np.column_stack([r[beams] * np.cos(a), r[beams] * np.sin(a), np.zeros(len(beams))])
    if pose is None:
        return local, beams
    m = np.asarray(pose, dtype=float)
    return local @ m[:3, :3].T + m[:3, 3], beams
