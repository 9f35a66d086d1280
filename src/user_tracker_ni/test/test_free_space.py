"""The laser's free-space memory: floor a beam passed through is free; where beams end is not;
a walker's next step is in free floor, a static leg's cell never is, nor the cell beside a leg
that stood still for a while."""

import math

import numpy as np
import pytest
from user_tracker_ni.free_space import FreeSpace, FreeSpaceParams

pytestmark = pytest.mark.unit

ANGLES = np.linspace(-math.pi / 2, math.pi / 2, 513)


def scan_with(points, wall=4.0):
    """Beam ends from the origin: a wall at x = ``wall``, and small round things at ``points``
    (x, y, radius) in front of it."""
    d = np.stack([np.cos(ANGLES), np.sin(ANGLES)], 1)
    with np.errstate(divide="ignore"):
        r = np.where(d[:, 0] > 1e-6, wall / d[:, 0], np.inf)
    for cx, cy, rad in points:
        b = d @ np.array([cx, cy])
        disc = b * b - (cx * cx + cy * cy - rad * rad)
        t = b - np.sqrt(np.where(disc >= 0, disc, np.nan))
        r = np.fmin(r, np.where((disc >= 0) & (t > 0), t, np.inf))
    hit = r <= 5.0
    return d * np.where(hit, r, 5.0)[:, None], hit


def test_floor_seen_through_is_free_and_what_ends_beams_is_not():
    fs = FreeSpace()
    for k in range(5):
        ends, hit = scan_with([(2.0, 0.5, 0.05)])
        fs.update(0.1 * k, (0.0, 0.0), ends, hit)
    free = fs.in_free_space([[1.0, 0.0], [2.0, 0.5], [3.99, 0.0], [4.5, 0.0], [-1.0, 0.0]])
    assert free.tolist() == [True, False, False, False, False]  # open floor; the leg; the wall; behind; unseen


def test_a_walkers_next_step_is_free_a_static_legs_cell_never_is():
    fs = FreeSpace()
    t = 0.0
    for k in range(30):  # a leg walking across at x = 2 (5 cm a scan) and one standing at (2.5, -1)
        y = -0.5 + 0.05 * k
        before = fs.in_free_space([[2.0, y], [2.5, -1.0]])
        ends, hit = scan_with([(2.0, y, 0.06), (2.5, -1.0, 0.06)])
        fs.update(t, (0.0, 0.0), ends, hit)
        t += 0.1
    assert before.tolist() == [True, False]


def test_a_still_persons_leg_a_cell_aside_is_not_free_a_walkers_stance_is():
    """A leg that stood at (2, 0.5) for 3 s, seen 6 cm aside (the robot's odometry drifted while it
    looked away): that cell was floor the beams passed beside the leg, but its neighbour ended
    beams steadily, so it is no newcomer. A walker's leg planted for 4 scans at (2, -0.5) leaves
    its next cell free, and so is the leg's cell before anything stood there."""
    p = FreeSpaceParams()
    fs = FreeSpace(p)
    t = 0.0
    for _ in range(30):
        ends, hit = scan_with([(2.0, 0.5, 0.06)])
        fs.update(t, (0.0, 0.0), ends, hit)
        t += 0.1
    aside = [2.0, 0.5 + 0.06 + 0.5 * p.resolution]
    alone = FreeSpace(FreeSpaceParams(neighbourhood=0))
    alone.free[:], alone.occupied[:], alone.origin = fs.free, fs.occupied, fs.origin
    assert alone.in_free_space([aside])[0]  # its own cell alone says free ...
    assert not fs.in_free_space([aside])[0]  # ... its neighbour does not
    for k in range(4):  # a stance of 0.4 s at (2, -0.5), then the next step 0.3 m on
        if k == 0:
            assert fs.in_free_space([[2.0, -0.5]])[0]
        ends, hit = scan_with([(2.0, 0.5, 0.06), (2.0, -0.5, 0.06)])
        fs.update(t, (0.0, 0.0), ends, hit)
        t += 0.1
    assert fs.in_free_space([[2.0, -0.2], [2.0, -0.5 + 0.06 + 0.5 * p.resolution]]).tolist() == [True, True]


def test_the_memory_fades_and_follows_the_robot():
    p = FreeSpaceParams(size=4.0, fade=1.0)
    fs = FreeSpace(p)
    ends, hit = scan_with([])
    for k in range(3):
        fs.update(0.1 * k, (0.0, 0.0), ends, hit)
    assert fs.in_free_space([[1.0, 0.0]])[0]
    fs.update(10.0, (1.5, 0.0), np.zeros((0, 2)), np.zeros(0, bool))  # 10 time constants later, moved
    assert not fs.in_free_space([[1.0, 0.0]])[0]
    assert fs.origin[0] > -1.0  # re-centred on the robot


def test_reset_and_bad_beams():
    fs = FreeSpace()
    ends, hit = scan_with([])
    ends[::3] = np.nan
    for k in range(3):
        fs.update(0.1 * k, (0.0, 0.0), ends, hit)
    assert fs.in_free_space([[1.0, 0.0]])[0]
    fs.reset()
    assert not fs.in_free_space([[1.0, 0.0]])[0]
    with pytest.raises(ValueError, match="max_occupied_ratio"):
        FreeSpaceParams(max_occupied_ratio=1.0).validate()
