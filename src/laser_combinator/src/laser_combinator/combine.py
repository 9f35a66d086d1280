"""Combination of the Hokuyo scan and the Kinect's fake scan (seed 3.7), ROS-free.

Both scans are expressed in the output frame (the laser's frame, ``frame_id``) through
4x4 homogeneous transforms the node takes from tf: each valid beam's end point is moved
into the output frame and projected onto its x-y plane, which gives its bearing and
distance there. This is how the upside-down Hokuyo (its y axis points to the robot's
right) and the upright Kinect line up: no index reversal, just geometry.

Each beam covers its angular width (one angle_increment); it lands in every output bin
whose centre lies inside that width, or in the nearest bin when it is narrower than a
bin. Per output bin the nearest reading wins. A reading is valid when it is finite and
within its own scan's [range_min, range_max]; bins without a valid reading get +inf
("no return", REP 117), which laser_filter later turns into a clearing beam.
"""

from dataclasses import dataclass

import numpy as np

TOL = 1e-6  # [bins] rounding slack so a beam on a bin centre maps to exactly that bin


@dataclass(frozen=True)
class Scan:
    angle_min: float  # [rad]
    angle_increment: float  # [rad]
    range_min: float  # [m]
    range_max: float  # [m]
    ranges: np.ndarray  # [m] float32


@dataclass(frozen=True)
class Grid:
    """The output grid: bin i is centred on angle_min + i * angle_increment."""

    angle_min: float  # [rad]
    angle_increment: float  # [rad] > 0
    size: int


def valid_mask(scan):
    r = scan.ranges
    with np.errstate(invalid="ignore"):
        return np.isfinite(r) & (r >= scan.range_min) & (r <= scan.range_max)


def crop_grid(scan, max_ang):
    """The Hokuyo grid restricted to [-max_ang, max_ang] (to the nearest step): (Grid, first index used)."""
    n = len(scan.ranges)
    inc = scan.angle_increment
    angles = scan.angle_min + inc * np.arange(n)
    # Half a step of slack: hokuyo_node rounds max_ang to whole steps (1.570 -> 256 steps = 1.5708).
    inside = np.flatnonzero(np.abs(angles) <= max_ang + 0.5 * abs(inc))
    if inside.size == 0:
        return Grid(scan.angle_min, abs(inc), 0), 0
    first, last = int(inside[0]), int(inside[-1])
    if inc < 0:  # a scan listed clockwise: the grid runs the other way
        first, last = last, first
    return Grid(float(angles[first]), abs(inc), int(abs(last - first)) + 1), first


def project(scan, transform):
    """Bearings [rad] and distances [m] in the output frame's x-y plane of the valid beams."""
    ok = valid_mask(scan)
    idx = np.flatnonzero(ok)
    a = scan.angle_min + scan.angle_increment * idx
    r = scan.ranges[idx].astype(np.float64)
    pts = np.vstack((r * np.cos(a), r * np.sin(a), np.zeros_like(r), np.ones_like(r)))
    x, y = (np.asarray(transform, dtype=np.float64) @ pts)[:2]
    return np.arctan2(y, x), np.hypot(x, y)


def nearest_per_bin(bearings, distances, beam_width, grid):
    """Per grid bin the smallest distance of the beams covering it (+inf where none)."""
    out = np.full(grid.size, np.inf, dtype=np.float64)
    if grid.size == 0 or bearings.size == 0:
        return out
    pos = (bearings - grid.angle_min) / grid.angle_increment  # [bins]
    half = 0.5 * abs(beam_width) / grid.angle_increment
    centre = np.rint(pos)
    lo = np.minimum(np.ceil(pos - half - TOL), centre).astype(np.int64)
    hi = np.maximum(np.ceil(pos + half - TOL) - 1, centre).astype(np.int64)
    lo = np.clip(lo, 0, grid.size)
    hi = np.clip(hi, -1, grid.size - 1)
    span = int(np.max(hi - lo, initial=-1)) + 1
    for k in range(min(span, grid.size)):
        j = lo + k
        use = j <= hi
        np.minimum.at(out, j[use], distances[use])
    return out


def to_grid(scan, transform, grid):
    bearings, distances = project(scan, transform)
    return nearest_per_bin(bearings, distances, scan.angle_increment, grid)


def combine(hokuyo, kinect, t_out_hokuyo, t_out_kinect, max_ang):
    """Combined ranges on the (cropped) Hokuyo grid: (Grid, float32 ranges, first Hokuyo index).

    ``t_out_hokuyo`` / ``t_out_kinect``: 4x4 transforms from each scan's frame into the
    output frame.
    """
    grid, first = crop_grid(hokuyo, max_ang)
    nearest = np.minimum(to_grid(hokuyo, t_out_hokuyo, grid), to_grid(kinect, t_out_kinect, grid))
    return grid, nearest.astype(np.float32), first
