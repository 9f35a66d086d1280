"""Evaluation helpers for amcl in the simulator, without ROS: a scripted tour of the apartment,
a waypoint follower, and the comparison of estimates with ground truth.

Used by the integration tests and bench/amcl.py.
"""

import math

import numpy as np

from florence_common import angles

# A loop through the shipped apartment (maps/apartment, map frame, metres), clear of furniture:
# living room -> corridor (door x 2.0..2.9) -> kitchen (door x 6.0..6.9) -> back to the living
# room through the opening at x = 5, y 1.5..3.0. One lap is about 18 m.
APARTMENT_LOOP = [(1.2, 4.8), (2.45, 4.9), (2.45, 6.15), (6.45, 6.15), (6.45, 4.6), (6.3, 2.25),
                  (4.2, 2.25), (1.0, 2.5)]
APARTMENT_START = (1.0, 2.5, 0.0)  # x [m], y [m], yaw [rad]


def path_length(start_xy, waypoints):
    points = np.vstack([start_xy, waypoints])
    return float(np.sum(np.hypot(*np.diff(points, axis=0).T)))


def tour(start_xy, loop, length):
    """Repeat the loop until the path is at least ``length`` [m] long; returns the waypoints."""
    lap = path_length(start_xy, loop)
    laps = max(1, math.ceil(length / lap))
    return [wp for _ in range(laps) for wp in loop]


def follow(pose, target, v_max=0.3, w_max=1.0, turn_in_place=0.35, tolerance=0.08):
    """Velocity (v [m/s], w [rad/s]) that drives a differential robot at pose (x, y, yaw) to target (x, y).

    Turns on the spot while the heading error exceeds ``turn_in_place`` [rad], else drives at v_max with a
    proportional heading correction. Returns (v, w, reached) with reached once within ``tolerance`` [m].
    """
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    dist = math.hypot(dx, dy)
    if dist < tolerance:
        return 0.0, 0.0, True
    err = float(angles.diff(math.atan2(dy, dx), pose[2]))
    w = max(-w_max, min(w_max, 2.0 * err))
    if abs(err) > turn_in_place:
        return 0.0, w, False
    v = min(v_max, 1.5 * dist) * math.cos(err)
    return max(0.05, v), w, False


def interpolate_poses(times, poses, query):
    """Poses [N, 3] at times [N] (increasing) interpolated at query times [M] (yaw unwrapped); NaN outside."""
    times, poses, query = np.asarray(times, float), np.asarray(poses, float), np.asarray(query, float)
    out = np.full((len(query), 3), np.nan)
    if len(times) < 2:
        return out
    inside = (query >= times[0]) & (query <= times[-1])
    yaw = np.unwrap(poses[:, 2])
    for i in range(2):
        out[inside, i] = np.interp(query[inside], times, poses[:, i])
    out[inside, 2] = np.interp(query[inside], times, yaw)
    return out


def estimate_errors(est_times, est_poses, truth_times, truth_poses):
    """Position error [m] and absolute yaw error [rad] of every estimate against interpolated truth."""
    truth = interpolate_poses(truth_times, truth_poses, est_times)
    est = np.asarray(est_poses, float).reshape(-1, 3)
    pos = np.hypot(est[:, 0] - truth[:, 0], est[:, 1] - truth[:, 1])
    yaw = np.abs(angles.diff(est[:, 2], truth[:, 2]))
    return pos, yaw


def rms(values):
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(values**2))) if values.size else float("nan")


def travelled(truth_poses):
    """Cumulative distance [m] along the truth poses [N, 3]."""
    poses = np.asarray(truth_poses, float)
    if len(poses) < 2:
        return np.zeros(len(poses))
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])


def convergence_index(pos_err, yaw_err, pos_tol=0.2, yaw_tol=0.1745, hold=5):
    """First index from which ``hold`` consecutive estimates are within tolerance (None if never).

    Default tolerances: 0.2 m and 0.1745 rad (10 deg).
    """
    ok = (np.asarray(pos_err) < pos_tol) & (np.asarray(yaw_err) < yaw_tol)
    run = 0
    for i, good in enumerate(ok):
        run = run + 1 if good else 0
        if run >= hold:
            return i - hold + 1
    return None
