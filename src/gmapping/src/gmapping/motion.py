"""GMapping's odometry motion model (openslam_gmapping ``motionmodel.cpp``, drawFromMotion), vectorised
over particles, without ROS.

The odometry step ``delta`` (the new odometry pose seen from the old one: x forward, y left, theta)
is disturbed per particle by zero-mean Gaussian noise with standard deviations

    x:     srr |dx| + str |dtheta| + 0.3 srr |dy|
    y:     srr |dy| + str |dtheta| + 0.3 srr |dx|
    theta: stt |dtheta| + srt sqrt(dx^2 + dy^2)

and composed onto each particle's pose. It runs on every scan, processed or not, as in GMapping.
"""

import numpy as np

from florence_common.pose import compose, relative


def sample_motion(poses, odom_new, odom_old, srr, srt, str_, stt, rng):
    """Poses [N, 3] (x [m], y [m], yaw [rad]) moved by the odometry step from ``odom_old`` to ``odom_new``
    (x, y, yaw) with GMapping's noise; ``rng`` a numpy Generator. Returns a new [N, 3] array."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    dx, dy, dth = relative(odom_old, odom_new)
    sigma = np.array([srr * abs(dx) + str_ * abs(dth) + 0.3 * srr * abs(dy),
                      srr * abs(dy) + str_ * abs(dth) + 0.3 * srr * abs(dx),
                      stt * abs(dth) + srt * np.hypot(dx, dy)])
    steps = np.tile([dx, dy, dth], (len(poses), 1))
    noisy = sigma > 0
    if noisy.any():
        steps[:, noisy] += rng.normal(0.0, sigma[noisy], size=(len(poses), int(noisy.sum())))
    return np.asarray(compose(poses, steps)).reshape(-1, 3)
