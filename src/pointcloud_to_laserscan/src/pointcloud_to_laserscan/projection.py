"""Depth data to a planar laser scan, ROS-free and vectorised.

Points (from a PointCloud2, or back-projected from a depth image with the pinhole model
of its camera_info) are expressed in two frames through 4x4 homogeneous transforms:

- the *target* frame of the scan: a point's bearing is atan2(y, x) and its range
  hypot(x, y) there (the scan lies in the target frame's x-y plane);
- the *height* frame (base_footprint on the robot, so heights are above the floor; the
  target frame itself reproduces the ROS package's behaviour): a point is kept when
  min_height <= z <= max_height there.

As in ROS's pointcloud_to_laserscan: points with range outside [range_min, range_max] or
bearing outside [angle_min, angle_max] are skipped, the nearest point per beam wins, and
beams without a point read +inf (use_inf) or range_max + inf_epsilon.

Depth images get a fast path: when the target frame's origin lies on the camera's
optical axis line in x-y (no x-y offset, e.g. camera_depth_frame for the optical frame),
each pixel's bearing does not depend on its depth, so pixels are sorted by beam once per
geometry and each image costs a few array operations.
"""

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ScanParams:
    """Parameters with the names of ROS's pointcloud_to_laserscan (units: m, rad, s)."""

    min_height: float = 0.0
    max_height: float = 1.0
    angle_min: float = -math.pi / 2
    angle_max: float = math.pi / 2
    angle_increment: float = math.pi / 360
    scan_time: float = 1.0 / 30
    range_min: float = 0.45
    range_max: float = 4.0
    use_inf: bool = True
    inf_epsilon: float = 1.0

    @property
    def size(self):
        return math.ceil((self.angle_max - self.angle_min) / self.angle_increment)

    def problems(self):
        out = []
        for name in ("min_height", "max_height", "angle_min", "angle_max", "angle_increment", "scan_time",
                     "range_min", "range_max", "inf_epsilon"):
            if not math.isfinite(getattr(self, name)):
                out.append(f"{name} must be finite, got {getattr(self, name)}")
        if out:
            return out
        if self.min_height > self.max_height:
            out.append(f"min_height ({self.min_height}) > max_height ({self.max_height})")
        if self.angle_increment <= 0:
            out.append(f"angle_increment must be > 0, got {self.angle_increment}")
        elif not self.angle_min < self.angle_max:
            out.append(f"angle_min ({self.angle_min}) must be < angle_max ({self.angle_max})")
        elif self.size > 100000:
            out.append(f"{self.size} beams: angle_increment too small")
        if not 0 <= self.range_min < self.range_max:
            out.append(f"need 0 <= range_min < range_max, got {self.range_min}, {self.range_max}")
        return out

    def no_return(self):
        return np.float32(np.inf if self.use_inf else self.range_max + self.inf_epsilon)


def nearest_per_beam(beam, ranges, size, fill):
    """Smallest range per beam index in [0, size) (``fill`` where none)."""
    out = np.full(size, fill, dtype=np.float32)
    if beam.size == 0:
        return out
    # A stable sort of 16-bit keys is a radix sort in numpy: O(n), several times faster.
    keys = beam.astype(np.int16) if size <= np.iinfo(np.int16).max else beam
    order = np.argsort(keys, kind="stable")
    sorted_beam = beam[order]
    starts = np.flatnonzero(np.r_[True, sorted_beam[1:] != sorted_beam[:-1]])
    out[sorted_beam[starts]] = np.minimum.reduceat(ranges[order], starts)
    return out


def beam_index(x, y, params):
    """Beam index of each point, -1 outside [angle_min, angle_max]."""
    angle = np.arctan2(y, x)
    idx = np.floor((angle - params.angle_min) / params.angle_increment).astype(np.int32)
    inside = (angle >= params.angle_min) & (angle <= params.angle_max) & (idx < params.size)
    return np.where(inside, idx, -1)


def points_to_ranges(points, t_target, t_height, params):
    """Ranges of the scan from an (N, 3) array of points in the source frame.

    ``t_target`` / ``t_height``: 4x4 transforms from the source frame into the target and
    the height frame. Non-finite points are ignored.
    """
    pts = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    rt = np.asarray(t_target, dtype=np.float32)
    rh = np.asarray(t_height, dtype=np.float32)
    x = pts @ rt[0, :3] + rt[0, 3]
    y = pts @ rt[1, :3] + rt[1, 3]
    h = pts @ rh[2, :3] + rh[2, 3]
    return planar_ranges(x, y, h, params)


def in_band(h, r, params):
    """Points whose height h [m] and range r [m] the scan keeps (NaN never)."""
    with np.errstate(invalid="ignore"):
        return (h >= params.min_height) & (h <= params.max_height) & (r >= params.range_min) & (r <= params.range_max)


def planar_ranges(x, y, h, params):
    """Scan ranges of points at (x, y) [m] in the target frame with heights h [m]."""
    r = np.hypot(x, y)
    keep = in_band(h, r, params)
    idx = beam_index(x[keep], y[keep], params)
    inside = idx >= 0
    return nearest_per_beam(idx[inside], r[keep][inside], params.size, params.no_return())


class DepthProjector:
    """Depth image (in the camera's optical frame, z forward) to scan ranges.

    Per-pixel rays and, on the fast path, the pixel order by beam are cached for the last
    (intrinsics, image size, transforms); the Kinect's tilt changing refreshes them.
    """

    def __init__(self, params):
        self.params = params
        self._key = None

    def _prepare(self, k, width, height, t_target, t_height):
        fx, fy, cx, cy = float(k[0]), float(k[4]), float(k[2]), float(k[5])
        if not (fx > 0 and fy > 0):
            raise ValueError(f"camera_info K has no focal length (fx={fx}, fy={fy})")
        u = (np.arange(width, dtype=np.float64) - cx) / fx
        v = (np.arange(height, dtype=np.float64) - cy) / fy
        rays = np.stack([np.broadcast_to(u, (height, width)), np.broadcast_to(v[:, None], (height, width)),
                         np.ones((height, width))]).reshape(3, -1)
        rt, rh = np.asarray(t_target, np.float64), np.asarray(t_height, np.float64)
        ax, ay = rt[0, :3] @ rays, rt[1, :3] @ rays
        self._ax, self._ay = ax.astype(np.float32), ay.astype(np.float32)
        self._tx, self._ty = np.float32(rt[0, 3]), np.float32(rt[1, 3])
        self._hz, self._h0 = (rh[2, :3] @ rays).astype(np.float32), np.float32(rh[2, 3])
        self._fast = abs(rt[0, 3]) < 1e-9 and abs(rt[1, 3]) < 1e-9
        if self._fast:
            self._scale = np.hypot(ax, ay).astype(np.float32)  # range per metre of depth
            beam = beam_index(ax, ay, self.params)
            pixels = np.flatnonzero(beam >= 0)
            order = np.argsort(beam[pixels], kind="stable")
            self._pixels = pixels[order]
            sorted_beam = beam[self._pixels]
            self._starts = np.flatnonzero(np.r_[True, sorted_beam[1:] != sorted_beam[:-1]]) if pixels.size else \
                np.zeros(0, np.int64)
            self._beams = sorted_beam[self._starts]

    def ranges(self, z, k, t_target, t_height):
        """Scan ranges from a (height, width) float32 depth array in metres (NaN = none)."""
        height, width = z.shape
        key = (tuple(float(v) for v in k), width, height, np.asarray(t_target, np.float64).tobytes(),
               np.asarray(t_height, np.float64).tobytes())
        if key != self._key:
            self._prepare(k, width, height, t_target, t_height)
            self._key = key
        p = self.params
        z = z.reshape(-1)
        h = z * self._hz + self._h0
        if self._fast:
            r = z * self._scale
            keep = in_band(h, r, p)
            out = np.full(p.size, p.no_return(), dtype=np.float32)
            if self._pixels.size:
                masked = np.where(keep, r, np.float32(np.inf))[self._pixels]
                out[self._beams] = np.minimum(np.minimum.reduceat(masked, self._starts), p.no_return())
            return out
        return planar_ranges(z * self._ax + self._tx, z * self._ay + self._ty, h, p)
