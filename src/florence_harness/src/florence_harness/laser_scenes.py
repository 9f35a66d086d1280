"""Synthetic laser scans of a flat world of wall segments: a small 2-D ray caster for the SLAM and scan
matching unit tests (independent of florence_sim's renderer, so the mapper is not tuned to one renderer).

A world is an array of segments [S, 4] (x0, y0, x1, y1) [m]; :func:`scan` gives the ranges of a laser at a
pose, beam by beam, as a LaserScan has them: counter-clockwise from ``angle_min`` in the laser's own frame,
+inf where nothing is within ``range_max``.
"""

import math

import numpy as np

URG_INCREMENT = 2.0 * math.pi / 1024  # [rad] the URG-04LX's step
UPSIDE_DOWN = np.array([[1.0, 0.0, 0.0, 0.06], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.165],
                        [0.0, 0.0, 0.0, 1.0]])  # the Florence Hokuyo on the base: rpy pi 0 0, 6 cm ahead
UPRIGHT = np.array([[1.0, 0.0, 0.0, 0.06], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.165], [0.0, 0.0, 0.0, 1.0]])


def box(x0, y0, x1, y1):
    """The four sides of an axis-aligned rectangle, as segments [4, 4]."""
    return np.array([[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]], float)


def room(width=6.0, depth=4.0):
    """A room with an L-shaped notch and two boxes in it (enough corners to pin every pose), [S, 4]."""
    walls = [[0, 0, width, 0], [width, 0, width, depth], [width, depth, 2.5, depth], [2.5, depth, 2.5, depth - 1.0],
             [2.5, depth - 1.0, 0, depth - 1.0], [0, depth - 1.0, 0, 0]]
    return np.vstack([np.array(walls, float), box(1.0, 0.8, 1.5, 1.2), box(4.2, 2.2, 4.6, 3.0)])


def corridor_loop():
    """A square loop of corridors around a block (outer 8 x 8 m, corridors 1.5 m wide, their middles at 0.75
    and 7.25 m) with a few 0.2 m posts along their walls, [S, 4]."""
    posts = [box(x, y, x + 0.2, y + 0.2) for x, y in [(0.0, 3.5), (4.0, 0.0), (7.8, 5.0), (2.5, 7.8), (5.5, 6.5)]]
    return np.vstack([box(0.0, 0.0, 8.0, 8.0), box(1.5, 1.5, 6.5, 6.5), *posts])


def scan(segments, pose, laser=UPSIDE_DOWN, angle_min=-math.pi / 2, angle_max=math.pi / 2,
         increment=URG_INCREMENT, range_max=5.6, noise=0.0, rng=None):
    """Ranges [B] (float32) of a planar laser mounted at ``laser`` (4x4 pose on the base) on a robot at
    ``pose`` (x, y, yaw), beams angle_min + i increment in the laser's frame; +inf where no segment is
    within range_max; Gaussian ``noise`` [m] on the hits."""
    angles = np.arange(angle_min, angle_max + 0.5 * increment, increment)
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    ox = x + c * laser[0, 3] - s * laser[1, 3]
    oy = y + s * laser[0, 3] + c * laser[1, 3]
    local = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1) @ laser[:3, :3].T
    dx = c * local[:, 0] - s * local[:, 1]
    dy = s * local[:, 0] + c * local[:, 1]
    seg = np.asarray(segments, float)
    ex, ey = seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]
    wx, wy = seg[:, 0] - ox, seg[:, 1] - oy
    denom = dx[:, None] * ey[None, :] - dy[:, None] * ex[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (wx[None, :] * ey[None, :] - wy[None, :] * ex[None, :]) / denom
        u = (wx[None, :] * dy[:, None] - wy[None, :] * dx[:, None]) / denom
    hit = (np.abs(denom) > 1e-12) & (t > 1e-9) & (u >= 0.0) & (u <= 1.0)
    ranges = np.where(hit, t, np.inf).min(axis=1)
    ranges[ranges > range_max] = np.inf
    if noise:
        finite = np.isfinite(ranges)
        ranges[finite] += (rng or np.random.default_rng(0)).normal(0.0, noise, int(finite.sum()))
    return ranges.astype(np.float32), float(angles[0]), increment
