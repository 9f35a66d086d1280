"""A pinhole depth camera's intrinsics (ROS-free): a sensor_msgs/CameraInfo's K as fx, fy, cx, cy
[px] with the image size, and the unit-depth rays of its pixels (a pixel at depth d [m] along the
optical axis is d times its ray, in the optical frame: x right, y down, z forward)."""

import functools
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Camera:
    """Pinhole intrinsics: focal lengths fx, fy [px], principal point cx, cy [px], size width x height [px]."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self):
        values = (self.fx, self.fy, self.cx, self.cy)
        if not (all(math.isfinite(v) for v in values) and self.fx > 0 and self.fy > 0):
            raise ValueError(f"no usable intrinsics: fx={self.fx}, fy={self.fy}, cx={self.cx}, cy={self.cy}")
        if not (self.width > 0 and self.height > 0):
            raise ValueError(f"image size {self.width}x{self.height}")

    @classmethod
    def from_k(cls, k, width, height):
        """From a CameraInfo's row-major 3x3 K [fx 0 cx 0 fy cy 0 0 1] and its size."""
        k = [float(v) for v in k]
        if len(k) != 9:
            raise ValueError(f"K must have 9 elements, got {len(k)}")
        return cls(k[0], k[4], k[2], k[5], int(width), int(height))

    def rays(self, stride=1, dtype=np.float64):
        """Unit-depth rays [h, w, 3] of every ``stride``-th row and column (read-only, cached)."""
        return _rays(self, int(stride), np.dtype(dtype).str)


def stride_for(width, target_width):
    """Every how many rows and columns to take so that about ``target_width`` columns remain."""
    return max(1, round(width / target_width))


@functools.lru_cache(maxsize=16)
def _rays(camera, stride, dtype):
    v, u = np.mgrid[0:camera.height:stride, 0:camera.width:stride].astype(dtype)
    rays = np.stack([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, np.ones_like(u)], -1).astype(dtype)
    rays.flags.writeable = False
    return rays
