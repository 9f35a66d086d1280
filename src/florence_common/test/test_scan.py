"""Laser scans as points (florence_common.scan)."""

import math

import numpy as np
import pytest

from florence_common import pose
from florence_common.scan import beam_angles, returns, scan_points

pytestmark = pytest.mark.unit


def test_returns_are_finite_ranges_inside_the_limits():
    r = [0.01, 0.5, math.inf, math.nan, 5.6, -1.0, 3.0]
    assert returns(r, 0.02, 5.6).tolist() == [False, True, False, False, False, False, True]


def test_points_in_the_scan_frame_and_in_another():
    ranges = [1.0, math.inf, 2.0]
    pts, beams = scan_points(ranges, -math.pi / 2, math.pi / 2, 0.02, 5.6)
    assert beams.tolist() == [0, 2]
    assert pts == pytest.approx(np.array([[0.0, -1.0, 0.0], [0.0, 2.0, 0.0]]), abs=1e-12)
    # a sensor 0.1 m ahead of the base, upside down (rolled by pi): its left is the base's right
    m = pose.planar_matrix(0.1, 0.0, 0.0) @ np.diag([1.0, -1.0, -1.0, 1.0])
    pts, _ = scan_points(ranges, -math.pi / 2, math.pi / 2, 0.02, 5.6, m)
    assert pts[:, :2] == pytest.approx(np.array([[0.1, 1.0], [0.1, -2.0]]), abs=1e-12)


def test_beam_angles():
    assert beam_angles(3, -1.0, 0.5) == pytest.approx([-1.0, -0.5, 0.0])
    assert scan_points([], 0.0, 0.1, 0.0, 1.0)[0].shape == (0, 3)
