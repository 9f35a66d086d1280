"""GMapping's odometry motion model."""

import math

import numpy as np
import pytest
from gmapping.motion import sample_motion

pytestmark = pytest.mark.unit


def test_no_motion_no_noise():
    poses = np.array([[1.0, 2.0, 0.5], [0.0, 0.0, -3.0]])
    out = sample_motion(poses, (4.0, 5.0, 1.0), (4.0, 5.0, 1.0), 0.1, 0.2, 0.1, 0.2, np.random.default_rng(1))
    np.testing.assert_allclose(out, poses, atol=1e-12)


def test_step_is_applied_in_each_particles_frame_with_the_documented_spread():
    """1 m straight ahead in odometry: a particle facing +y moves +y; x noise srr * 1 m, yaw noise srt * 1 m."""
    n = 20000
    poses = np.tile([0.0, 0.0, math.pi / 2], (n, 1))
    out = sample_motion(poses, (2.0, 0.0, 0.0), (1.0, 0.0, 0.0), 0.1, 0.2, 0.1, 0.2, np.random.default_rng(2))
    assert np.mean(out[:, 1]) == pytest.approx(1.0, abs=0.005)
    assert np.std(out[:, 1]) == pytest.approx(0.1, rel=0.05)  # along the motion: srr |dx|
    assert np.std(out[:, 0]) == pytest.approx(0.03, rel=0.05)  # across: 0.3 srr |dx|
    assert np.std(out[:, 2]) == pytest.approx(0.2, rel=0.05)  # yaw: srt |d|


def test_rotation_noise_from_stt():
    n = 20000
    out = sample_motion(np.zeros((n, 3)), (0.0, 0.0, 0.5), (0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 0.2,
                        np.random.default_rng(3))
    assert np.mean(out[:, 2]) == pytest.approx(0.5, abs=0.005)
    assert np.std(out[:, 2]) == pytest.approx(0.1, rel=0.05)
    np.testing.assert_allclose(out[:, :2], 0.0)
