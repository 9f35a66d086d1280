"""The SLAM bench's measures (florence_eval.slam_metrics) and the mapping tour's driver (florence_eval.tour)."""

import math

import numpy as np
import pytest
from florence_eval.tour import MAPPING_TOUR, TourDriver, tour_length

from florence_common import pose
from florence_eval import slam_metrics

pytestmark = pytest.mark.unit

FREE, UNKNOWN, OCC = 0, -1, 100


def test_alignment_recovers_a_rigid_motion_and_ate_is_zero_after_it():
    rng = np.random.default_rng(1)
    truth = np.column_stack([rng.uniform(0, 8, 50), rng.uniform(0, 10, 50), rng.uniform(-3, 3, 50)])
    frame = (1.0, 2.5, 0.3)  # the estimate's frame in the world
    est = np.array(pose.relative(frame, truth))
    theta, t = slam_metrics.align_se2(est[:, :2], truth[:, :2])
    assert theta == pytest.approx(0.3) and t == pytest.approx([1.0, 2.5])
    pos, yaw, _ = slam_metrics.trajectory_errors(est, truth)
    assert pos.max() < 1e-9 and yaw.max() < 1e-9
    pos, _, _ = slam_metrics.trajectory_errors(est, truth, anchor=frame)
    assert pos.max() < 1e-9
    shifted = est + np.array([0.05, 0.0, 0.0])
    assert slam_metrics.rms(slam_metrics.trajectory_errors(shifted, truth, anchor=frame)[0]) == pytest.approx(0.05)


def room(shift=0):
    """A 40 x 30 cell room (walls 2 cells thick), free inside, unknown outside; ``shift`` cells east."""
    g = np.full((34, 44), UNKNOWN, np.int8)
    g[2:32, 2:42] = OCC
    g[4:30, 4:40] = FREE
    return np.roll(g, shift, axis=1)


def test_map_scores_count_within_one_cell_and_free_space_strictly():
    truth = room()
    seen = truth.copy()
    scores = slam_metrics.map_scores(truth, truth, seen)
    assert scores["occupied_f1"] == 1.0 and scores["free_agreement"] == 1.0 and scores["free_coverage"] == 1.0
    # the visible wall cells: only the inner faces, not the walls' insides (which nobody can see)
    assert scores["visible_occupied_cells"] == (truth == OCC).sum()  # seen = truth here: every wall cell
    one = slam_metrics.map_scores(room(1), truth, seen)
    assert one["occupied_precision"] == 1.0 and one["occupied_recall"] == 1.0
    assert one["free_agreement"] < 1.0 and one["free_in_walls"] == 26  # a column of free cells in the east wall
    three = slam_metrics.map_scores(room(3), truth, seen)
    assert three["occupied_f1"] < 0.6


def test_seen_cells_limit_the_recall():
    truth = room()
    seen = np.full(truth.shape, UNKNOWN, np.int8)
    seen[4:30, 4:40] = FREE
    seen[5:29, 4] = OCC  # only the west wall was seen (the cells its beams ended in): a map with only it is complete
    built = np.full(truth.shape, UNKNOWN, np.int8)
    built[4:30, 4:40] = FREE
    built[4:30, 3] = OCC
    scores = slam_metrics.map_scores(built, truth, seen)
    assert scores["occupied_recall"] == 1.0 and scores["occupied_precision"] == 1.0


def test_resample_into_places_a_rotated_map():
    truth = room()
    data = truth.copy()
    # the same map in a frame turned 90 deg about the world's origin, then carried back
    rotated = np.rot90(data, k=-1)  # rows are y: a frame turned +90 deg sees the map turned -90 deg
    w = data.shape[1]
    back = slam_metrics.resample_into(rotated, (0.0, -w * 0.05), 0.05, math.pi / 2, (0.0, 0.0), data.shape,
                                      (0.0, 0.0), 0.05)
    assert np.mean(back == data) > 0.99


def test_the_tour_spins_and_waits_for_a_clear_corridor():
    driver = TourDriver([("spin",), ("clear", 0.0, 5.5, 8.0, 6.8), ("go", 1.0, 1.0)])
    yaw = 0.0
    for _ in range(200):
        v, w = driver.command((0.0, 0.0, yaw), [(3.0, 6.0, 0.0, 0.0)])
        if driver.index > 0:
            break
        assert v == 0.0 and w > 0.0
        yaw = float(np.angle(np.exp(1j * (yaw + 0.05))))
    assert driver.index == 1
    assert driver.command((0.0, 0.0, 0.0), [(3.0, 6.0, 0.0, 0.0)]) == (0.0, 0.0)  # somebody in the corridor
    assert driver.command((0.0, 0.0, 0.0), [(3.0, 5.0, 0.0, 0.4)]) == (0.0, 0.0)  # walking into it
    v, w = driver.command((0.0, 0.0, 0.0), [(3.0, 5.0, 0.0, -0.4)])  # walking away: go
    assert driver.index == 2 and (v, w) != (0.0, 0.0)
    assert tour_length((1.0, 2.5), MAPPING_TOUR) > 35.0


def test_the_driver_steps_aside_for_a_person_who_waits_for_it():
    """A person stands on the robot's line 0.6 m ahead (waiting for the robot, as florence_sim's people do): the
    driver waits, steps aside to a free spot, lets them pass and comes back to its line."""
    driver = TourDriver([("go", 5.0, 0.0)], clearance=lambda x, y: 1.0 - abs(y) if abs(y) < 1.0 else 0.0)
    robot = (0.0, 0.0, 0.0)
    person = [(0.6, 0.0, 0.0, 0.0)]
    waited = 0.0
    while not driver.detour and waited < 5.0:
        assert driver.command(robot, person, dt=0.05) == (0.0, 0.0)
        waited += 0.05
    assert waited == pytest.approx(TourDriver.SIDESTEP_AFTER, abs=0.06)
    assert len(driver.detour) == 2 and driver.sidesteps == 1
    assert driver.command(robot, person)[1] != 0.0  # turns towards the spot
    spot = driver.detour[0]
    assert abs(spot[1]) == pytest.approx(0.7) and spot[0] == pytest.approx(0.0)
    assert driver.detour[1] == (0.0, 0.0)
    # at the spot it holds while the person is near, then goes back to where it left its line
    at_spot = (spot[0], spot[1], 0.0)
    passing = [(0.2, 0.0, 0.5, 0.0)]
    assert driver.command(at_spot, passing) == (0.0, 0.0)
    assert driver.holding is not None and driver.detour == [(0.0, 0.0)]
    driver.command(at_spot, [(3.0, 0.0, 0.5, 0.0)])
    assert driver.holding is None and driver.detour == [(0.0, 0.0)]
