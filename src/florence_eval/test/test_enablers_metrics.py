"""florence_eval.enablers_metrics: following judged on true tracks, and the perfect follower beside it."""

import numpy as np
import pytest

from florence_eval import enablers_metrics as em

pytestmark = pytest.mark.unit


def walk_east(speed, start=(1.0, 0.0), stand=2.0, seconds=10.0, dt=0.1):
    """A person's rows (t, x, y): standing ``stand`` s at ``start``, then walking east at ``speed``."""
    t = np.arange(0.0, stand + seconds + 1e-9, dt)
    x = start[0] + speed * np.clip(t - stand, 0.0, None)
    return np.column_stack([t, x, np.full(len(t), start[1])])


def test_a_robot_that_keeps_the_distance_has_no_error():
    person = walk_east(0.5)
    robot = np.column_stack([person[:, 0], person[:, 1] - 1.0, person[:, 2], np.zeros(len(person))])
    out = em.following(robot, person, [], [], 1.0, 2.0, 12.0)
    assert out["rms_error_m"] == pytest.approx(0.0, abs=1e-9) and out["min_distance_m"] == pytest.approx(1.0)


def test_a_perfect_follower_only_loses_what_it_cannot_see():
    """Walking away at the top speed: seeing her at once, the robot loses only its acceleration (0.5 m/s
    at 1 m/s^2: 0.125 m, at most); seeing her 0.6 s late, about 0.6 s of her walk more, kept to the end
    since it is no faster than she is."""
    person = walk_east(0.5, stand=2.0, seconds=10.0)
    at_once = em.ideal_following(person, (0.0, 0.0), 1.0, 2.0, 12.0)
    late = em.ideal_following(person, (0.0, 0.0), 1.0, 2.0, 12.0, delay=0.6)
    assert at_once["max_error_m"] == pytest.approx(0.125, abs=0.02)
    assert at_once["rms_error_m"] < 0.13
    assert late["max_error_m"] == pytest.approx(0.125 + 0.3, abs=0.03)
    assert late["mean_distance_m"] > at_once["mean_distance_m"] + 0.2
    # slower than the robot's top speed, a lag is made up
    slow = em.ideal_following(walk_east(0.3, stand=2.0, seconds=10.0), (0.0, 0.0), 1.0, 2.0, 12.0, delay=0.6)
    assert slow["max_error_m"] < late["max_error_m"] and slow["rms_error_m"] < late["rms_error_m"]


def test_a_perfect_follower_on_her_trail_cuts_no_corner():
    """She walks 3 m east from 1 m ahead, turns north and walks 3 m more at the top speed: straight at
    her, the follower makes up at the corner what it lost setting off; on her trail (as follow_me goes)
    it does not, and loses what a straight walk of the same length costs."""
    t = np.arange(0.0, 16.0 + 1e-9, 0.1)
    walked = 0.5 * np.clip(t - 2.0, 0.0, 12.0)
    x = 1.0 + np.minimum(walked, 3.0)
    y = np.clip(walked - 3.0, 0.0, 3.0)
    corner = np.column_stack([t, x, y])
    straight_walk = np.column_stack([t, 1.0 + np.minimum(walked, 6.0), np.zeros(len(t))])
    at_her = em.ideal_following(corner, (0.0, 0.0), 1.0, 2.0, 16.0, delay=0.3)
    on_trail = em.ideal_following(corner, (0.0, 0.0), 1.0, 2.0, 16.0, delay=0.3, along_trail=True)
    same_length = em.ideal_following(straight_walk, (0.0, 0.0), 1.0, 2.0, 16.0, delay=0.3)
    assert on_trail["rms_error_m"] == pytest.approx(same_length["rms_error_m"], abs=1e-3)
    assert on_trail["rms_error_m"] > at_her["rms_error_m"] + 0.03
    assert on_trail["max_error_m"] == pytest.approx(0.125 + 0.15, abs=0.03)  # its acceleration and 0.3 s of her walk
    line = em.straightened(corner, (0.0, 0.0), 2.0)
    assert line[-1, 1] == pytest.approx(7.0) and np.all(line[:, 2] == 0.0)


def test_a_perfect_follower_closes_in_on_a_person_standing_farther_and_stops_at_the_distance():
    person = walk_east(0.0, start=(1.5, 0.0), stand=0.0, seconds=10.0)
    out = em.ideal_following(person, (0.0, 0.0), 1.0, 0.0, 10.0)
    assert out["max_error_m"] == pytest.approx(0.5, abs=1e-6)  # at the start
    last = em.ideal_following(person, (0.0, 0.0), 1.0, 0.0, 10.0, dt=0.01)
    assert last["mean_distance_m"] < 1.15 and out["mean_distance_m"] < 1.15


def test_the_monitors_first_hold_is_placed_in_the_map():
    """EnablersSession.monitor_held (no master: the session's logs set by hand): the first slowed, stopped
    or blind judgement since the trial's start, its nearest point through the robot's true pose."""
    import math
    import threading

    from florence_eval.enablers_session import EnablersSession

    session = EnablersSession.__new__(EnablersSession)  # its logs only: no subscribers
    session.lock = threading.Lock()
    session.monitor = [(1.0, "stop", 0.3, 0.0, "before the trial", 0.4, 0.0),
                       (5.0, "clear", 0.3, 0.3, "clear", math.nan, math.nan),
                       (6.0, "slow", 0.3, 0.1, "slowed to 33%", 0.5, -0.1),
                       (7.0, "stop", 0.3, 0.0, "stopped", 0.3, 0.0)]
    track = np.array([[4.0, 1.0, 2.0, 0.0], [6.0, 1.0, 2.0, np.pi / 2], [7.0, 1.0, 2.2, np.pi / 2]])
    held = session.monitor_held(4.5, track)
    assert held["state"] == "slow" and held["reason"] == "slowed to 33%" and held["t"] == 6.0
    assert held["nearest"] == pytest.approx([1.1, 2.5])  # 0.5 ahead, 0.1 to the right of a robot facing north
    session.monitor = session.monitor[:2]
    assert session.monitor_held(4.5, track) is None
