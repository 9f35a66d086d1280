"""Tracker judgement against ground truth: frames in the robot's base frame, the Kinect's view,
returns under the old id."""

import math

import numpy as np
import pytest
from florence_eval.people_metrics import KinectView, evaluate, frames, interpolate_poses

pytestmark = pytest.mark.unit


def test_view():
    view = KinectView(x=0.0, y=0.0)
    inside = view.sees([(2.0, 0.0), (0.5, 0.0), (4.5, 0.0), (2.0, 1.5), (-2.0, 0.0), (3.0, 1.2)])
    assert inside.tolist() == [True, False, False, False, False, True]


def test_interpolation_takes_the_short_way_round():
    times, poses = np.array([0.0, 1.0]), np.array([[0.0, 0.0, math.pi - 0.1], [1.0, 0.0, -math.pi + 0.1]])
    x, _, yaw = interpolate_poses(times, poses, 0.5)
    assert x == 0.5 and math.cos(yaw) == pytest.approx(-1.0)
    assert interpolate_poses(times, poses, 2.0) is None


def test_odometry_drift_does_not_count_against_the_tracker():
    """The robot believes it is 0.3 m further east than it is; the tracker sees the person where the
    robot perceives them: in the base frame both agree."""
    truth = (np.array([0.0, 10.0]), np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0]]))
    odom = (np.array([0.0, 10.0]), np.array([[1.3, 1.0, 0.0], [1.3, 1.0, 0.0]]))
    people = [(t, {"alice": (3.0, 1.0)}) for t in np.arange(0, 10, 0.1)]
    tracks = [(t, {7: (3.3, 1.02)}, {7: 1}) for t in np.arange(0.05, 9.9, 0.1)]
    result = evaluate(frames(tracks, people, truth, odom, KinectView()))
    assert result["mota"] == 1.0 and result["motp_m"] == pytest.approx(0.02)


def test_a_person_out_of_view_counts_for_nothing_and_returns_are_judged():
    truth = odom = (np.array([0.0, 20.0]), np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]))
    people, tracks = [], []
    for t in np.arange(0, 20, 0.1):
        x = 2.0 if t < 5 or t >= 10 else -2.0  # behind the robot between 5 and 10 s
        people.append((t, {"bob": (x, 0.0)}))
    for t in np.arange(0.05, 19.9, 0.1):
        if t < 5:
            tracks.append((t, {3: (2.0, 0.0)}, {3: 1}))
        elif t >= 10:
            tracks.append((t, {3 if t < 15 else 4: (2.0, 0.0)}, {3: 2, 4: 3}))
        else:
            tracks.append((t, {}, {}))
    result = evaluate(frames(tracks, people, truth, odom, KinectView()))
    assert result["misses"] == 0, "behind the robot, not in the Kinect's view: not a miss"
    assert (result["returns"], result["returns_with_old_id"]) == (1, 1)
    assert result["id_switches"] == 1  # at 15 s the id changed under a visible person
