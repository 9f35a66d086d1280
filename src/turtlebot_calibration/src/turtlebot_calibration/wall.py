"""The wall in front of the robot, from scan points in the robot's base frame (ROS-free).

The node turns every beam of a scan into a point (x [m], y [m]) in ``base_footprint`` through
tf, so the fit does not care how the laser is mounted: the Kinect's narrow fake laser and the
upside-down Hokuyo (whose beams run clockwise about the robot's z axis) give the same angle. The
original scan_to_angle.py fitted a slope in the laser's own frame, which mirrors the angle of an
inverted laser (turtlebot_apps #59).

Fit: points ahead of the robot (bearing within ``max_bearing``, range within
``min_range..max_range``) are kept; a line is picked among candidate pairs of points by the number
of points within ``inlier_distance`` of it (so a chair leg or a person's shin in front of the wall
does not tilt it), then refined by a total least-squares fit (principal axis) of its inliers.

Angle convention: ``Wall.angle`` [rad] is the robot's heading relative to the wall's normal,
counter-clockwise positive (REP 103), 0 when the robot faces the wall squarely. When the robot
turns by +d, the angle grows by d, as the gyro's and the odometry's yaw do; the wall's normal
direction seen from the robot is (cos(-angle), sin(-angle)).
"""

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WallConfig:
    """What counts as a wall in front. Lengths [m], angles [rad]."""

    max_bearing: float = 0.35  # [rad] points within this bearing of straight ahead (base frame)
    min_range: float = 0.15  # [m] nearer points are the robot or noise
    max_range: float = 3.0  # [m] farther points are not used
    inlier_distance: float = 0.03  # [m] a point this close to the line lies on the wall
    min_points: int = 15  # on the wall
    min_span: float = 0.25  # [m] extent of the wall's points along it
    max_rms: float = 0.02  # [m] of the wall's points about the fitted line
    min_inlier_fraction: float = 0.5  # of the points ahead
    max_angle: float = 1.0  # [rad] a "wall" seen more obliquely is not the one in front

    def validate(self):
        for name in ("max_bearing", "max_range", "inlier_distance", "min_span", "max_rms", "max_angle"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if not (0 <= self.min_range < self.max_range):
            raise ValueError(f"min_range {self.min_range} must be >= 0 and below max_range {self.max_range}")
        if self.min_points < 2:
            raise ValueError(f"min_points must be at least 2, got {self.min_points}")
        if not (0 < self.min_inlier_fraction <= 1):
            raise ValueError(f"min_inlier_fraction must be within (0, 1], got {self.min_inlier_fraction}")
        return self


@dataclass(frozen=True)
class Wall:
    angle: float  # [rad] robot heading relative to the wall's normal, CCW positive, 0 = facing it
    distance: float  # [m] from the base frame's origin to the wall's line
    rms: float  # [m] of the inliers about the line
    points: int  # inliers
    span: float  # [m] extent of the inliers along the wall


def scan_points(ranges, angle_min, angle_increment, range_min, range_max, laser_to_base):
    """Points [N, 2] (x, y [m]) in the base frame of a LaserScan's valid beams (finite, within
    range_min..range_max; NaN, inf and out-of-range readings are dropped). ``laser_to_base`` is the
    4x4 pose of the scan's frame in the base frame (tf): an upside-down laser's rotation about x
    mirrors its beams here, once, for every user."""
    r = np.asarray(ranges, dtype=float)
    angles = angle_min + angle_increment * np.arange(len(r))
    ok = np.isfinite(r) & (r >= range_min) & (r <= range_max)
    r, angles = r[ok], angles[ok]
    local = np.stack([r * np.cos(angles), r * np.sin(angles), np.zeros_like(r), np.ones_like(r)])
    return (np.asarray(laser_to_base, dtype=float) @ local)[:2].T


def points_ahead(points, config):
    """The rows of ``points`` [N, 2] (base frame) that may belong to a wall in front: finite, ahead
    within ``max_bearing``, range within ``min_range..max_range``; sorted by bearing."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    rng = np.hypot(pts[:, 0], pts[:, 1])
    bearing = np.arctan2(pts[:, 1], pts[:, 0])
    keep = (np.abs(bearing) <= config.max_bearing) & (rng >= config.min_range) & (rng <= config.max_range)
    pts, bearing = pts[keep], bearing[keep]
    return pts[np.argsort(bearing, kind="stable")]


def _principal_line(pts):
    """(centroid, unit direction) of the total least-squares line through ``pts`` [N, 2]."""
    centroid = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - centroid, full_matrices=False)
    return centroid, vt[0]


def _best_candidate(pts, tolerance):
    """Inlier mask of the best line through a pair of points (most inliers, then least residual).
    The pairs are each point with the ones a half and a quarter of the scan further on, so every
    candidate spans a good part of the view."""
    n = len(pts)
    idx = np.arange(n)
    pairs = np.concatenate([np.stack([idx, (idx + n // 2) % n], axis=1),
                            np.stack([idx, (idx + max(1, n // 4)) % n], axis=1)])
    a, b = pts[pairs[:, 0]], pts[pairs[:, 1]]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    ok = length > 1e-6
    a, d, length = a[ok], d[ok], length[ok]
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1) / length[:, None]  # [M, 2]
    residual = np.abs((pts[None, :, :] - a[:, None, :]) @ normal[..., None])[..., 0]  # [M, N]
    inlier = residual <= tolerance
    count = inlier.sum(axis=1)
    cost = np.where(inlier, residual, tolerance).sum(axis=1)
    best = np.lexsort((cost, -count))[0]
    return inlier[best]


def fit_wall(points, config=None):
    """(Wall, None) for the straight wall in front of the robot in ``points`` [N, 2] (x, y [m] in
    the base frame), or (None, reason) saying why there is none. ``config``: a WallConfig."""
    config = config or WallConfig()
    pts = points_ahead(points, config)
    ahead = len(pts)
    where = (f"within {math.degrees(config.max_bearing):.0f} deg of straight ahead and "
             f"{config.min_range:.2f}-{config.max_range:.1f} m")
    if ahead < config.min_points:
        return None, f"{ahead} readings {where} (at least {config.min_points} needed)"
    inlier = _best_candidate(pts, config.inlier_distance)
    for _ in range(3):  # refine: fit the inliers, take the points near the fitted line, again
        if inlier.sum() < 2:
            break
        centroid, direction = _principal_line(pts[inlier])
        normal = np.array([-direction[1], direction[0]])
        new = np.abs((pts - centroid) @ normal) <= config.inlier_distance
        if np.array_equal(new, inlier):
            break
        inlier = new
    count = int(inlier.sum())
    if count < config.min_points or count < config.min_inlier_fraction * ahead:
        return None, (f"the {ahead} readings {where} do not lie on a straight wall "
                      f"(at most {count} within {100 * config.inlier_distance:.0f} cm of a line)")
    wall_pts = pts[inlier]
    centroid, direction = _principal_line(wall_pts)
    normal = np.array([-direction[1], direction[0]])
    if normal @ centroid < 0:
        normal = -normal  # from the robot towards the wall
    residual = (wall_pts - centroid) @ normal
    rms = float(np.sqrt(np.mean(residual**2)))
    along = wall_pts @ direction
    span = float(along.max() - along.min())
    angle = -math.atan2(normal[1], normal[0])
    if span < config.min_span:
        return None, f"the wall's readings span only {span:.2f} m (at least {config.min_span:.2f} m needed)"
    if rms > config.max_rms:
        return None, f"the readings ahead are not a straight wall ({100 * rms:.1f} cm rms about a line)"
    if abs(angle) > config.max_angle:
        return None, (f"the only straight line ahead runs at {math.degrees(angle):.0f} deg to the robot's "
                      f"heading: not a wall in front")
    return Wall(angle=angle, distance=float(normal @ centroid), rms=rms, points=count, span=span), None
