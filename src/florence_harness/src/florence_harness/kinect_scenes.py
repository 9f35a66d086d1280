"""Synthetic depth and colour images of a level Florence Kinect (0.54 m high): a small ray caster
of vertical cylinders (people, clutter) and vertical walls, for the people detector's unit tests
(independent of florence_sim's renderer, so the detector is not tuned to one renderer only)."""

import math

import numpy as np

from florence_common import pose

WIDTH, HEIGHT = 160, 120
HFOV = math.radians(57.0)


def intrinsics(width, height):
    """K (row-major 3x3) of a pinhole camera of the Kinect's horizontal field of view."""
    f = (width / 2) / math.tan(HFOV / 2)
    return [f, 0.0, (width - 1) / 2, 0.0, f, (height - 1) / 2, 0.0, 0.0, 1.0]


K = intrinsics(WIDTH, HEIGHT)
CAMERA_HEIGHT = 0.54  # [m]
# optical frame (z forward, x right, y down) in the base frame (x forward, y left, z up)
CAMERA_POSE = pose.transform_matrix((0.0, 0.0, CAMERA_HEIGHT), (-0.5, 0.5, -0.5, 0.5))
SKIN, TROUSERS = (220, 180, 150), (50, 50, 60)


def standing(x, y, shirt, height=1.72, build=1.0):
    """Cylinders (cx, cy, r, z0, z1, rgb) of a standing person facing the camera."""
    legs = 0.85 * height / 1.72
    return [(x, y + 0.10, 0.065 * build, 0.0, legs, TROUSERS), (x, y - 0.10, 0.065 * build, 0.0, legs, TROUSERS),
            (x, y, 0.18 * build, legs, height - 0.24, shirt), (x, y, 0.10, height - 0.22, height, SKIN)]


def sitting(x, y, shirt, facing=math.pi, reach=0.15):
    """Cylinders of a seated person whose lower legs stand ``reach`` [m] in front of the torso, facing
    ``facing`` [rad] in the base frame (pi: toward the camera)."""
    c, s = math.cos(facing), math.sin(facing)
    lx, ly = x + reach * c, y + reach * s
    return [(lx - 0.08 * s, ly + 0.08 * c, 0.06, 0.0, 0.48, TROUSERS),
            (lx + 0.08 * s, ly - 0.08 * c, 0.06, 0.0, 0.48, TROUSERS),
            (x, y, 0.17, 0.45, 1.05, shirt), (x, y, 0.10, 1.10, 1.32, SKIN)]


def coat_stand(x, y):
    return [(x, y, 0.02, 0.0, 1.75, (90, 60, 40)), (x + 0.05, y, 0.22, 1.05, 1.65, (60, 70, 50))]


def floor_lamp(x, y):
    return [(x, y, 0.15, 0.0, 0.03, (30, 30, 30)), (x, y, 0.015, 0.0, 1.45, (30, 30, 30)),
            (x, y, 0.20, 1.40, 1.70, (240, 230, 200))]


def tall_plant(x, y):
    return [(x, y, 0.18, 0.0, 0.40, (150, 80, 50)), (x, y, 0.03, 0.40, 0.95, (90, 70, 40)),
            (x, y, 0.36, 0.95, 1.85, (40, 120, 40))]


def render(cylinders=(), walls=(), noise=0.0, seed=0, width=WIDTH, height=HEIGHT):
    """(depth [m] float32 with NaN, rgb uint8) of a level Kinect at the origin looking along +x.

    walls: (x0, y0, x1, y1, rgb[, top]) vertical faces from the floor to ``top`` [m] (2.4 m)."""
    k = intrinsics(width, height)
    v, u = np.mgrid[0:height, 0:width].astype(float)
    rays = np.stack([(u - k[2]) / k[0], (v - k[5]) / k[4], np.ones_like(u)], -1) @ CAMERA_POSE[:3, :3].T
    o = CAMERA_POSE[:3, 3]
    best = np.full((height, width), np.inf)
    rgb = np.zeros((height, width, 3), np.uint8)
    dx, dy, dz = rays[..., 0], rays[..., 1], rays[..., 2]
    for cx, cy, r, z0, z1, col in cylinders:
        a = dx * dx + dy * dy
        b = 2 * (dx * (o[0] - cx) + dy * (o[1] - cy))
        c = (o[0] - cx) ** 2 + (o[1] - cy) ** 2 - r * r
        disc = b * b - 4 * a * c
        with np.errstate(invalid="ignore"):
            s = (-b - np.sqrt(disc)) / (2 * a)
        zh = o[2] + s * dz
        hit = (disc >= 0) & (s > 0) & (zh >= z0) & (zh <= z1) & (s < best)
        best[hit], rgb[hit] = s[hit], col
    for wall in walls:
        x0, y0, x1, y1, col = wall[:5]
        top = wall[5] if len(wall) > 5 else 2.4  # [m]
        ex, ey = x1 - x0, y1 - y0
        den = dx * ey - dy * ex
        with np.errstate(divide="ignore", invalid="ignore"):
            s = ((x0 - o[0]) * ey - (y0 - o[1]) * ex) / den
            w = ((x0 - o[0]) * dy - (y0 - o[1]) * dx) / den
        zh = o[2] + s * dz
        hit = (s > 0) & (w >= 0) & (w <= 1) & (zh >= 0) & (zh <= top) & (s < best)
        best[hit], rgb[hit] = s[hit], col
    # floor
    with np.errstate(divide="ignore", invalid="ignore"):
        s = -o[2] / dz
    hit = (dz < 0) & (s < best)
    best[hit], rgb[hit] = s[hit], (150, 130, 100)
    depth = best * 1.0  # the optical z of a unit-z ray is the ray parameter
    if noise:
        with np.errstate(invalid="ignore"):
            depth = depth + np.random.default_rng(seed).normal(0, 1, depth.shape) * noise * depth * depth
    depth = np.where(np.isfinite(depth) & (depth <= 4.5), depth, np.nan).astype(np.float32)
    return depth, rgb
