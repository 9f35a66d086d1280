"""Evaluation helpers: waypoint follower, tour length, interpolation of truth, errors and convergence."""

import math

import numpy as np
import pytest
from florence_eval.tour import (
    APARTMENT_LOOP,
    APARTMENT_START,
    convergence_index,
    estimate_errors,
    follow,
    interpolate_poses,
    path_length,
    rms,
    tour,
    travelled,
)

pytestmark = pytest.mark.unit


@pytest.mark.parametrize(("pose", "target", "expect"), [
    ((0, 0, 0), (1, 0), "drive"),              # straight ahead
    ((0, 0, 0), (0, 1), "turn_left"),          # 90 deg to the left: turn on the spot
    ((0, 0, 0), (0, -1), "turn_right"),
    ((0, 0, 0), (0.05, 0), "reached"),
])
def test_follow(pose, target, expect):
    v, w, reached = follow(pose, target)
    if expect == "drive":
        assert v == pytest.approx(0.3) and w == pytest.approx(0.0) and not reached
    elif expect == "turn_left":
        assert v == 0.0 and w > 0
    elif expect == "turn_right":
        assert v == 0.0 and w < 0
    else:
        assert reached and v == 0.0 and w == 0.0


def test_follow_reaches_every_waypoint_kinematically():
    pose = np.array(APARTMENT_START, dtype=float)
    dt = 0.05
    for target in APARTMENT_LOOP:
        for _ in range(2000):
            v, w, reached = follow(pose, target)
            if reached:
                break
            pose += [v * dt * math.cos(pose[2]), v * dt * math.sin(pose[2]), w * dt]
        assert reached, f"did not reach {target}"


def test_tour_length():
    lap = path_length(APARTMENT_START[:2], APARTMENT_LOOP)
    assert 17.0 < lap < 19.0
    waypoints = tour(APARTMENT_START[:2], APARTMENT_LOOP, 30.0)
    assert len(waypoints) == 2 * len(APARTMENT_LOOP)


def test_interpolation_and_errors():
    times = np.array([0.0, 1.0, 2.0])
    poses = np.array([[0, 0, 3.0], [1, 0, -3.0], [2, 0, -2.9]])  # yaw crosses +-pi
    mid = interpolate_poses(times, poses, np.array([0.5, 3.0]))
    assert mid[0, 0] == pytest.approx(0.5)
    assert abs(math.remainder(mid[0, 2] - math.pi, 2 * math.pi)) < 0.2  # near pi, not near 0
    assert np.isnan(mid[1]).all()
    pos, yaw = estimate_errors([0.5], [[0.5, 0.3, 3.0 + (2 * math.pi - 6.0) / 2]], times, poses)
    assert pos[0] == pytest.approx(0.3)
    assert yaw[0] == pytest.approx(0.0, abs=1e-9)
    assert rms([3.0, 4.0, np.nan]) == pytest.approx(math.sqrt(12.5))


def test_travelled_and_convergence():
    poses = np.array([[0, 0, 0], [3, 4, 0], [3, 5, 0]])
    assert travelled(poses).tolist() == [0.0, 5.0, 6.0]
    pos = np.array([2.0, 0.1, 0.1, 1.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1])
    assert convergence_index(pos, np.zeros(10), hold=5) == 4
    assert convergence_index(np.ones(10), np.zeros(10)) is None
