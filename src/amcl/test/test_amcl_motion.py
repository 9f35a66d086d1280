"""Odometry motion models: decomposition, noise statistics of diff (ROS's original) and diff-corrected."""

import math

import numpy as np
import pytest
from amcl.motion import decompose, noise_scales, sample_motion

from florence_common import angles

pytestmark = pytest.mark.unit

ALPHAS = (0.2, 0.2, 0.2, 0.2, 0.2)


@pytest.mark.parametrize(("old", "new", "expected"), [
    ((0, 0, 0), (1, 0, 0), (0.0, 1.0, 0.0)),                      # straight ahead
    ((0, 0, 0), (0, 0, 0.5), (0.0, 0.0, 0.5)),                    # turn on the spot
    ((0, 0, 0), (0.005, 0.0, 0.3), (0.0, 0.005, 0.3)),            # < 1 cm: pure rotation
    ((0, 0, 0), (-1, 0, 0), (-math.pi, 1.0, math.pi)),            # backwards: rot1 of pi
    ((1, 1, math.pi / 2), (1, 2, math.pi / 2), (0.0, 1.0, 0.0)),  # ahead while facing +y
    ((0, 0, 0), (1, 1, math.pi / 2), (math.pi / 4, math.sqrt(2), math.pi / 4)),
])
def test_decompose(old, new, expected):
    rot1, trans, rot2 = decompose(np.array(old, float), np.array(new, float))
    assert abs(angles.diff(rot1, expected[0])) < 1e-9
    assert trans == pytest.approx(expected[1])
    assert abs(angles.diff(rot2, expected[2])) < 1e-9


def test_zero_alphas_move_exactly():
    particles = np.array([[1.0, 2.0, 0.3], [-1.0, 0.0, -2.0]])
    out = sample_motion(particles, np.array([0, 0, 0.0]), np.array([0.5, 0.0, 0.2]), (0, 0, 0, 0, 0), "diff")
    for p, q in zip(particles, out, strict=True):
        assert q[0] == pytest.approx(p[0] + 0.5 * math.cos(p[2]))
        assert q[1] == pytest.approx(p[1] + 0.5 * math.sin(p[2]))
        assert q[2] == pytest.approx(p[2] + 0.2)


@pytest.mark.parametrize(("model", "expected_std"), [
    # A 0.5 m straight step with alpha3 = 0.2: the book's translation std is sqrt(0.2 * 0.25) = 0.2236 m;
    # ROS's original "diff" uses the variance 0.2 * 0.25 = 0.05 as the std.
    ("diff-corrected", math.sqrt(0.2 * 0.25)),
    ("diff", 0.2 * 0.25),
])
def test_translation_noise_statistics(model, expected_std):
    rng = np.random.default_rng(7)
    n = 40000
    out = sample_motion(np.zeros((n, 3)), np.zeros(3), np.array([0.5, 0.0, 0.0]), ALPHAS, model, rng)
    along = out[:, 0] * np.cos(0) + out[:, 1] * np.sin(0)
    # Along-track spread is dominated by trans noise (rot1 noise only bends it slightly).
    assert np.mean(along) == pytest.approx(0.5, abs=4 * expected_std / math.sqrt(n) + 0.01)
    assert np.std(out[:, 2]) > 0
    trans_hat = np.hypot(out[:, 0], out[:, 1]) * np.sign(along)
    assert np.std(trans_hat) == pytest.approx(expected_std, rel=0.05)


@pytest.mark.parametrize(("model", "expected_std"), [
    # A pure 0.4 rad turn: rot2 std = alpha1 * 0.4^2 = 0.032 (diff) or sqrt(alpha1) * 0.4 = 0.179 (corrected).
    ("diff", 0.2 * 0.4**2),
    ("diff-corrected", math.sqrt(0.2) * 0.4),
])
def test_rotation_noise_statistics(model, expected_std):
    rng = np.random.default_rng(3)
    out = sample_motion(np.zeros((40000, 3)), np.zeros(3), np.array([0.0, 0.0, 0.4]), ALPHAS, model, rng)
    assert np.mean(out[:, 2]) == pytest.approx(0.4, abs=0.01)
    assert np.std(out[:, 2]) == pytest.approx(expected_std, rel=0.05)


def test_reversing_is_not_a_half_turn_of_noise():
    """Backwards motion: rot1 = pi, but its noise is measured against pi (ROS), so it stays small."""
    scales = noise_scales(np.zeros(3), np.array([-0.3, 0.0, 0.0]), ALPHAS, corrected=True)
    assert scales[0] == pytest.approx(math.sqrt(0.2) * 0.3)
    rng = np.random.default_rng(1)
    out = sample_motion(np.zeros((5000, 3)), np.zeros(3), np.array([-0.3, 0.0, 0.0]), ALPHAS, "diff", rng)
    assert np.mean(out[:, 0]) == pytest.approx(-0.3, abs=0.01)
    assert np.max(np.abs(angles.diff(out[:, 2], 0.0))) < 0.5


def test_unknown_model_is_rejected():
    with pytest.raises(ValueError, match="odom_model_type"):
        sample_motion(np.zeros((1, 3)), np.zeros(3), np.zeros(3), ALPHAS, "omni")
