"""Odometry motion models of ROS amcl (sample_motion_model_odometry), vectorised over particles.

Poses are arrays [..., 3] of (x [m], y [m], yaw [rad]).

``diff`` reproduces ROS amcl's original differential model, including its known defect:
the noise terms ``alpha1 * rot^2 + alpha2 * trans^2`` etc. are *variances* in
Probabilistic Robotics (table 5.6) but the original code passes them to the Gaussian
sampler as *standard deviations*. With the usual alphas (0.2) and small steps that makes
the noise much smaller than the book's. ``diff-corrected`` uses the square roots (the
book's model); ROS recommends much smaller alphas with it (e.g. 0.005 .. 0.05).
The difference matters for global localization: resampling duplicates particles and only
the motion noise spreads the copies. With ``diff``, alphas 0.2 and 0.1 m updates that noise
is a few millimetres, so copies of a particle 0.2 m off the true pose never reach it
(see amcl_turtlebot_control.launch, which uses diff-corrected for that reason).

Both decompose the odometry step into rot1 / trans / rot2, and, like ROS, measure the
rotation noise against the nearer of "forward" and "backward" so that reversing does
not look like a half-turn.
"""

import numpy as np

from florence_common import angles

MODELS = ("diff", "diff-corrected")


def decompose(old_odom, new_odom):
    """Odometry step (old pose -> new pose, odom frame) to (rot1 [rad], trans [m], rot2 [rad])."""
    dx, dy = new_odom[0] - old_odom[0], new_odom[1] - old_odom[1]
    trans = float(np.hypot(dx, dy))
    # Below 1 cm the heading of the step is noise: ROS treats it as a pure rotation.
    rot1 = 0.0 if trans < 0.01 else float(angles.diff(np.arctan2(dy, dx), old_odom[2]))
    rot2 = float(angles.diff(angles.diff(new_odom[2], old_odom[2]), rot1))
    return rot1, trans, rot2


def noise_scales(old_odom, new_odom, alphas, corrected):
    """The three standard deviations (rot1, trans, rot2) the model samples with."""
    a1, a2, a3, a4 = alphas[:4]
    rot1, trans, rot2 = decompose(old_odom, new_odom)
    rot1_n = min(abs(angles.diff(rot1, 0.0)), abs(angles.diff(rot1, np.pi)))
    rot2_n = min(abs(angles.diff(rot2, 0.0)), abs(angles.diff(rot2, np.pi)))
    terms = np.array([a1 * rot1_n**2 + a2 * trans**2,
                      a3 * trans**2 + a4 * rot1_n**2 + a4 * rot2_n**2,
                      a1 * rot2_n**2 + a2 * trans**2])
    return np.sqrt(terms) if corrected else terms


def sample_motion(particles, old_odom, new_odom, alphas, model="diff", rng=None):
    """Move every particle by the odometry step old_odom -> new_odom with noise; returns new array.

    particles: [N, 3]; old_odom, new_odom: (x, y, yaw) of the base in the odom frame;
    alphas: (alpha1, alpha2, alpha3, alpha4[, alpha5]) (alpha5 is for omni models, unused).
    """
    if model not in MODELS:
        raise ValueError(f"odom_model_type must be one of {MODELS}, got {model!r}")
    rng = np.random.default_rng() if rng is None else rng
    particles = np.asarray(particles, dtype=float)
    n = particles.shape[0]
    rot1, trans, rot2 = decompose(old_odom, new_odom)
    s_rot1, s_trans, s_rot2 = noise_scales(old_odom, new_odom, alphas, model == "diff-corrected")
    rot1_hat = angles.diff(rot1, rng.normal(0.0, 1.0, n) * s_rot1)
    trans_hat = trans - rng.normal(0.0, 1.0, n) * s_trans
    rot2_hat = angles.diff(rot2, rng.normal(0.0, 1.0, n) * s_rot2)
    out = np.empty_like(particles)
    heading = particles[:, 2] + rot1_hat
    out[:, 0] = particles[:, 0] + trans_hat * np.cos(heading)
    out[:, 1] = particles[:, 1] + trans_hat * np.sin(heading)
    out[:, 2] = angles.wrap(heading + rot2_hat)
    return out
