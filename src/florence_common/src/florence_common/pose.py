"""Poses and rotations: 2-D pose maths (REP 103: x forward, y left, yaw counter-clockwise)
and the quaternion and matrix forms ROS messages carry.

A 2-D pose is ``(x [m], y [m], yaw [rad])``; :func:`compose`, :func:`inverse` and
:func:`relative` also take arrays ``[..., 3]`` of poses (broadcasting) and answer one pose
with a tuple of floats, several with an ndarray [..., 3]; yaws come out in [-pi, pi).
``compose(a, b)`` is "b, expressed in frame a, seen from a's parent": the pose of a laser
(b, in the base frame) on a robot at a (in the map) is ``compose(robot, laser)``. Quaternions are ``(x, y, z, w)`` as in
geometry_msgs and scipy; conversions go through :mod:`scipy.spatial.transform`.
"""

import math

import numpy as np
from scipy.spatial.transform import Rotation

from florence_common.angles import wrap


def _split(p):
    p = np.asarray(p, dtype=float)
    return p[..., 0], p[..., 1], p[..., 2]


def _pack(x, y, yaw):
    """One pose as a tuple of floats, several as an ndarray [..., 3]."""
    out = np.stack([x, y, wrap(yaw)], axis=-1)
    return tuple(float(v) for v in out) if out.ndim == 1 else out


def compose(a, b):
    """Pose ``b`` (given in frame ``a``) in ``a``'s parent frame: a ⊕ b."""
    ax, ay, ath = _split(a)
    bx, by, bth = _split(b)
    c, s = np.cos(ath), np.sin(ath)
    return _pack(ax + c * bx - s * by, ay + s * bx + c * by, ath + bth)


def inverse(p):
    """The pose of the parent frame seen from frame ``p``: ⊖p, so compose(p, inverse(p)) = 0."""
    x, y, th = _split(p)
    c, s = np.cos(th), np.sin(th)
    return _pack(-c * x - s * y, s * x - c * y, -th)


def relative(a, b):
    """Pose ``b`` expressed in frame ``a`` (both given in the same parent): ⊖a ⊕ b."""
    return compose(inverse(a), b)


def transform_points(pose, points):
    """Points ``[N, 2]`` given in frame ``pose`` to its parent frame ([N, 2] array)."""
    x, y, th = (float(v) for v in pose)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    c, s = math.cos(th), math.sin(th)
    return np.column_stack([x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]])


def segment_distances(points, a, b):
    """Distances [N] of ``points`` [N, 2] from the segment ``a``-``b`` (a point when a == b)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ab = b - a
    t = np.clip(((pts - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
    return np.hypot(*(pts - (a + t[:, None] * ab)).T)


def to_matrix(pose):
    """3x3 homogeneous matrix of a 2-D pose."""
    x, y, th = (float(v) for v in pose)
    c, s = math.cos(th), math.sin(th)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def from_matrix(m):
    """(x, y, yaw) of a 3x3 homogeneous matrix, or of the planar part of a 4x4 transform."""
    m = np.asarray(m, dtype=float)
    if m.shape == (4, 4):
        return float(m[0, 3]), float(m[1, 3]), yaw_of_matrix(m[:3, :3])
    return float(m[0, 2]), float(m[1, 2]), float(math.atan2(m[1, 0], m[0, 0]))


def yaw_to_quaternion(yaw):
    """Quaternion (x, y, z, w) of a rotation by ``yaw`` [rad] about z; [..., 4] for an array."""
    q = Rotation.from_euler("z", np.asarray(yaw, dtype=float)).as_quat()
    return tuple(float(v) for v in q) if np.ndim(yaw) == 0 else q


def quaternion_to_yaw(q):
    """Yaw [rad] of quaternion(s) (x, y, z, w): the z angle of the z-y'-x'' (yaw, pitch, roll)
    decomposition, as tf's getYaw. Raises ValueError for a zero quaternion."""
    yaw = Rotation.from_quat(np.asarray(q, dtype=float)).as_euler("ZYX")[..., 0]
    return float(yaw) if np.ndim(yaw) == 0 else yaw


def yaw_of_matrix(r):
    """Yaw [rad] of a 3x3 rotation matrix (z-y'-x'' decomposition)."""
    return float(Rotation.from_matrix(np.asarray(r, dtype=float)).as_euler("ZYX")[0])


def quaternion_to_rpy(q):
    """(roll, pitch, yaw) [rad] of quaternion (x, y, z, w), fixed axes x, y, z (URDF rpy)."""
    return tuple(float(a) for a in Rotation.from_quat(np.asarray(q, dtype=float)).as_euler("xyz"))


def rpy_to_matrix(rpy):
    """3x3 rotation of URDF's (roll, pitch, yaw) [rad] (fixed axes x, y, z)."""
    return Rotation.from_euler("xyz", np.asarray(rpy, dtype=float)).as_matrix()


def axis_angle_matrix(axis, angle):
    """3x3 rotation by ``angle`` [rad] about the unit vector ``axis`` (a URDF joint's axis)."""
    return Rotation.from_rotvec(np.asarray(axis, dtype=float) * float(angle)).as_matrix()


def transform_matrix(translation, quaternion):
    """4x4 homogeneous transform of a translation (x, y, z) [m] and a quaternion (x, y, z, w)."""
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(np.asarray(quaternion, dtype=float)).as_matrix()
    m[:3, 3] = np.asarray(translation, dtype=float)
    return m


def matrix_to_transform(m):
    """(translation (x, y, z), quaternion (x, y, z, w)) of a 4x4 homogeneous transform."""
    m = np.asarray(m, dtype=float)
    return tuple(float(v) for v in m[:3, 3]), tuple(float(v) for v in Rotation.from_matrix(m[:3, :3]).as_quat())


def planar_matrix(x, y, yaw):
    """4x4 homogeneous transform of a 2-D pose (z = 0, rotation about z)."""
    m = np.eye(4)
    m[:2, :2] = to_matrix((x, y, yaw))[:2, :2]
    m[0, 3], m[1, 3] = x, y
    return m


def beams_in_plane(laser_pose, angles):
    """Where a planar laser's beams go in its robot's plane: (origin (x, y) [m], bearings [B] [rad], up).

    ``laser_pose``: 4x4 pose of the laser frame in the robot's frame (from tf); ``angles`` [B]: the beam
    angles in the laser frame (a LaserScan's angle_min + i angle_increment). Each beam's direction goes
    through the full 3-D rotation and is projected onto the robot's x/y plane, so a laser mounted upside
    down (roll pi) simply gets mirrored bearings: no special case. ``up`` is the z component of the
    laser's z axis in the robot frame: 1 upright, -1 upside down, anything between a tilted laser whose
    beams leave the plane.
    """
    m = np.asarray(laser_pose, dtype=float)
    angles = np.asarray(angles, dtype=float)
    rotation = m[:3, :3]
    dx = rotation[0, 0] * np.cos(angles) + rotation[0, 1] * np.sin(angles)
    dy = rotation[1, 0] * np.cos(angles) + rotation[1, 1] * np.sin(angles)
    return m[:2, 3].copy(), np.arctan2(dy, dx), float(rotation[2, 2])
