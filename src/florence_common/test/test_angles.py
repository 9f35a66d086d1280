"""The workspace's angle convention: wrap to [-pi, pi), diff(a, b) = a - b."""

import math

import numpy as np
import pytest

from florence_common import angles

pytestmark = pytest.mark.unit


@pytest.mark.parametrize(("a", "expected"), [
    (0.0, 0.0), (math.pi, -math.pi), (-math.pi, -math.pi), (3 * math.pi, -math.pi), (2 * math.pi, 0.0),
    (math.pi / 2, math.pi / 2), (-3 * math.pi / 2, math.pi / 2), (7.0, 7.0 - 2 * math.pi), (-1e-20, -1e-20),
])
def test_wrap_is_in_minus_pi_to_pi(a, expected):
    assert angles.wrap(a) == pytest.approx(expected, abs=1e-12)
    assert isinstance(angles.wrap(a), float)


def test_wrap_never_returns_plus_pi():
    tiny = np.array([-1e-20, -1e-300, -5e-324, 0.0, math.pi, -math.pi, 3 * math.pi])
    out = angles.wrap(tiny)
    assert np.all(out >= -math.pi) and np.all(out < math.pi)
    for a in tiny:
        assert -math.pi <= angles.wrap(float(a)) < math.pi


def test_wrap_vectorised_matches_scalar():
    rng = np.random.default_rng(1)
    a = rng.uniform(-50, 50, 1000)
    out = angles.wrap(a)
    assert out.shape == a.shape
    assert np.allclose(out, [angles.wrap(float(v)) for v in a])
    assert np.allclose(np.cos(out), np.cos(a)) and np.allclose(np.sin(out), np.sin(a))


def test_diff_is_a_minus_b():
    # the rotation that takes b to a: from heading 0.1 to 0.3 is +0.2 (counter-clockwise, REP 103)
    assert angles.diff(0.3, 0.1) == pytest.approx(0.2)
    assert angles.diff(0.1, 0.3) == pytest.approx(-0.2)
    # across the cut: from 179 deg to -179 deg is +2 deg, not -358
    assert angles.diff(math.radians(-179), math.radians(179)) == pytest.approx(math.radians(2))
    assert np.allclose(angles.diff([0.3, -3.1], [0.1, 3.1]), [0.2, 2 * math.pi - 6.2])


def test_wrap_scalar_compiles_with_numba():
    numba = pytest.importorskip("numba")
    kernel = numba.njit(angles.wrap_scalar)
    for a in (0.0, math.pi, -math.pi, 10.0, -10.0):
        assert kernel(a) == pytest.approx(angles.wrap(a))


def test_circular_mean():
    assert angles.circular_mean([math.pi - 0.1, -math.pi + 0.1]) == pytest.approx(-math.pi)
    assert angles.circular_mean([0.0, 1.0], weights=[1.0, 0.0]) == pytest.approx(0.0)
