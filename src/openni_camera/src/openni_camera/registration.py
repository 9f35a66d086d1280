"""11-bit depth to metres, depth registered to the colour camera, and the coloured point cloud.

ROS-free (numpy, numba). Everything that does not change from frame to frame is computed once
(:class:`Registration`): the raw-to-metres table, the depth camera's pixel rays, the colour
camera's pixel rays. Per frame there are two compiled passes over the pixels:

1. :meth:`Registration.register`: each depth pixel's raw value -> depth [m] (table) -> point
   in the depth optical frame -> the colour camera's frame (R, t) -> the colour pixel it falls
   on (rounded), where the nearest point wins (z-buffer: a foreground object hides what the
   colour camera cannot see behind it). A colour pixel left empty between two filled
   neighbours of the same surface (within 2 % in depth) takes their mean: the rounding of the
   shift, which varies with depth, leaves such one-pixel gaps along rows.
2. :meth:`Registration.cloud`: per colour pixel, x = (u - cx) / fx * z, y = (v - cy) / fy * z,
   z, and the pixel's colour packed as PCL does (0x00RRGGBB in the bytes of a float32):
   16 bytes a point, organised as the image, NaN where there is no depth.

Lens distortion is not corrected (the Kinect's defaults have none); the intrinsics' skew is
taken as zero.
"""

import math

import numba
import numpy as np

from openni_camera import kinect


@numba.njit(cache=True, nogil=True)
def _register(raw, table, ray_x, ray_y, rot, t, fx, fy, cx, cy, out):  # pragma: no cover - compiled
    height, width = raw.shape
    out_h, out_w = out.shape
    out[:, :] = np.inf
    for v in range(height):
        for u in range(width):
            z = table[raw[v, u]]
            if not z > 0.0:  # NaN: no return
                continue
            x = ray_x[u] * z
            y = ray_y[v] * z
            px = rot[0, 0] * x + rot[0, 1] * y + rot[0, 2] * z + t[0]
            py = rot[1, 0] * x + rot[1, 1] * y + rot[1, 2] * z + t[1]
            pz = rot[2, 0] * x + rot[2, 1] * y + rot[2, 2] * z + t[2]
            if pz <= 0.0:
                continue
            iu = math.floor(fx * px / pz + cx + 0.5)
            iv = math.floor(fy * py / pz + cy + 0.5)
            if 0 <= iu < out_w and 0 <= iv < out_h and pz < out[iv, iu]:
                out[iv, iu] = pz
    _fill_gaps(out)


@numba.njit(cache=True, nogil=True)
def _register_shift(raw, table, inverse, col, row, shift_u, shift_v, out):  # pragma: no cover - compiled
    """_register for a colour camera only translated across the image plane (no rotation, no
    offset along the axis): the colour pixel is col[u] + shift_u / z, row[v] + shift_v / z
    (col and row already hold the intrinsics and the + 0.5 of rounding)."""
    height, width = raw.shape
    out_h, out_w = out.shape
    out[:, :] = np.inf
    for v in range(height):
        r = row[v]
        for u in range(width):
            code = raw[v, u]
            z = table[code]
            if not z > 0.0:
                continue
            fu = col[u] + shift_u * inverse[code]
            fv = r + shift_v * inverse[code]
            if fu < 0.0 or fv < 0.0:
                continue
            iu = int(fu)
            iv = int(fv)
            if iu < out_w and iv < out_h and z < out[iv, iu]:
                out[iv, iu] = z
    _fill_gaps(out)


@numba.njit(cache=True, nogil=True)
def _fill_gaps(out):  # pragma: no cover - compiled
    out_h, out_w = out.shape
    for v in range(out_h):
        for u in range(1, out_w - 1):
            if out[v, u] == np.inf:
                a = out[v, u - 1]
                b = out[v, u + 1]
                if a < np.inf and b < np.inf and abs(a - b) <= 0.02 * min(a, b):
                    out[v, u] = 0.5 * (a + b)
    for v in range(out_h):
        for u in range(out_w):
            if out[v, u] == np.inf:
                out[v, u] = np.nan


@numba.njit(cache=True, nogil=True)
def _cloud(depth, rgb, ray_x, ray_y, xyz, packed):  # pragma: no cover - compiled
    height, width = depth.shape
    for v in range(height):
        for u in range(width):
            z = depth[v, u]
            xyz[v, u, 0] = ray_x[u] * z
            xyz[v, u, 1] = ray_y[v] * z
            xyz[v, u, 2] = z
            packed[v, u, 3] = (np.uint32(rgb[v, u, 0]) << 16) | (np.uint32(rgb[v, u, 1]) << 8) | np.uint32(rgb[v, u, 2])


POINT_FIELDS = (("x", 0), ("y", 4), ("z", 8), ("rgb", 12))  # FLOAT32 each; rgb holds 0x00RRGGBB
POINT_STEP = 16  # [bytes]


class Registration:
    """Depth [m] from 11-bit raw frames of the depth camera ``depth`` (camera_info.CameraInfo),
    registered to the colour camera ``rgb`` placed at ``rgb_in_depth`` (x, y, z) [m] (and
    rotated by ``rotation``, 3x3, default none) in the depth camera's optical frame."""

    def __init__(self, depth, rgb, rgb_in_depth=kinect.RGB_IN_DEPTH, rotation=None, baseline=kinect.BASELINE,
                 disparity_offset=kinect.DISPARITY_OFFSET):
        self.depth_info, self.rgb_info = depth, rgb
        self.table = kinect.raw_to_metres_table(depth.fx, baseline, disparity_offset)
        self.depth_ray_x = ((np.arange(depth.width) - depth.cx) / depth.fx).astype(np.float64)
        self.depth_ray_y = ((np.arange(depth.height) - depth.cy) / depth.fy).astype(np.float64)
        self.rgb_ray_x = ((np.arange(rgb.width) - rgb.cx) / rgb.fx).astype(np.float32)
        self.rgb_ray_y = ((np.arange(rgb.height) - rgb.cy) / rgb.fy).astype(np.float32)
        # the colour camera's pose in the depth frame -> a depth-frame point in the colour frame
        rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64).reshape(3, 3)
        self.rot = np.ascontiguousarray(rot.T)
        self.t = -self.rot @ np.asarray(rgb_in_depth, dtype=np.float64)
        # no rotation and no offset along the axis (the Kinect's cameras): a shift by 1/z per pixel
        self.shift_only = bool(np.allclose(self.rot, np.eye(3)) and abs(self.t[2]) < 1e-9)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.inverse = np.where(np.isfinite(self.table), 1.0 / self.table, 0.0).astype(np.float64)
        self.col = rgb.fx * self.depth_ray_x + rgb.cx + 0.5
        self.row = rgb.fy * self.depth_ray_y + rgb.cy + 0.5

    def warm_up(self):
        """Compile (or load from numba's cache) both passes now, not on the first frame."""
        raw = np.full((2, 2), kinect.RAW_NO_VALUE, dtype=np.uint16)
        out = np.empty((2, 2), dtype=np.float32)
        _register(raw, self.table, self.depth_ray_x, self.depth_ray_y, self.rot, self.t, 1.0, 1.0, 0.0, 0.0, out)
        _register_shift(raw, self.table, self.inverse, self.col[:2], self.row[:2], 1.0, 1.0, out)
        cloud = np.empty((2, 2, 4), dtype=np.float32)
        _cloud(out, np.zeros((2, 2, 3), dtype=np.uint8), self.rgb_ray_x, self.rgb_ray_y, cloud, cloud.view(np.uint32))
        return self

    def metres(self, raw):
        """float32 (H, W) depth [m] on the depth camera's grid of a raw (H, W) uint16 frame."""
        return np.take(self.table, raw)

    def register(self, raw, out=None):
        """float32 depth [m] on the colour camera's grid (z in its optical frame), NaN where no
        depth pixel lands."""
        r = self.rgb_info
        if out is None:
            out = np.empty((r.height, r.width), dtype=np.float32)
        if self.shift_only:
            _register_shift(raw, self.table, self.inverse, self.col, self.row, r.fx * self.t[0], r.fy * self.t[1], out)
        else:
            _register(raw, self.table, self.depth_ray_x, self.depth_ray_y, self.rot, self.t, r.fx, r.fy, r.cx, r.cy,
                      out)
        return out

    def cloud(self, depth, rgb, out=None):
        """(H, W, 4) float32 of a registered depth (H, W) [m] and its colour image (H, W, 3) uint8:
        x, y, z [m] in the colour optical frame and the packed colour (bytes of a uint32); its
        bytes are a PointCloud2's data with :data:`POINT_FIELDS`. ``out``: an array to fill (a
        4.9 MB allocation a frame costs page faults)."""
        h, w = depth.shape
        if rgb.shape[:2] != (h, w):
            raise ValueError(f"colour image {rgb.shape[1]}x{rgb.shape[0]} does not match the depth {w}x{h}")
        if out is None or out.shape != (h, w, 4):
            out = np.empty((h, w, 4), dtype=np.float32)
        _cloud(depth, rgb, self.rgb_ray_x, self.rgb_ray_y, out, out.view(np.uint32))
        return out
