"""StandingPlace: a standing person's place from the far sightings; close ones only keep it."""

import pytest
from approach_me.estimate import StandingPlace

pytestmark = pytest.mark.unit


def test_far_sightings_are_averaged_and_near_ones_leave_the_place():
    place = StandingPlace(far_range=1.0, still_radius=0.15)
    for k, x in enumerate((2.02, 1.98, 2.01, 1.99)):  # the robot 1.6 m away: noisy but unbiased
        place.update((x, 0.0), (0.4, 0.0), 0.1 * k)
    assert place.xy == pytest.approx((2.0, 0.0), abs=1e-9)
    # close up the torso is cut at the image's edge: the sightings slide 0.1 m sideways
    for k in range(30):
        assert place.update((2.0, 0.1), (1.4, 0.0), 1.0 + 0.1 * k) == pytest.approx((2.0, 0.0), abs=1e-9)


def test_a_person_who_moves_starts_the_place_over():
    place = StandingPlace(far_range=1.0, still_radius=0.15, move_time=0.5)
    place.update((2.0, 0.0), (0.0, 0.0), 0.0)
    assert place.update((2.3, 0.0), (0.0, 0.0), 1.0) == (2.0, 0.0)  # one sighting off: not yet
    assert place.update((2.3, 0.0), (0.0, 0.0), 1.3) == (2.0, 0.0)
    assert place.update((2.3, 0.0), (0.0, 0.0), 1.5) == (2.3, 0.0)  # 0.5 s off: they moved
    # a single outlier between good sightings does not count toward moving
    place.update((2.6, 0.0), (0.0, 0.0), 2.0)
    place.update((2.3, 0.0), (0.0, 0.0), 2.1)
    assert place.update((2.6, 0.0), (0.0, 0.0), 2.4) == (2.3, 0.0)


def test_near_sightings_count_until_a_far_one_comes():
    place = StandingPlace(far_range=1.0)
    place.update((1.0, 0.1), (0.3, 0.0), 0.0)  # the goal came with the robot close
    place.update((1.0, 0.0), (0.3, 0.0), 0.1)
    assert place.xy == pytest.approx((1.0, 0.05))
    place.update((1.0, 0.02), (-0.2, 0.0), 0.2)  # backed off: the first far sighting replaces them
    assert place.xy == pytest.approx((1.0, 0.02))


def test_the_mean_follows_a_slow_drift_within_its_window():
    place = StandingPlace(far_range=1.0, still_radius=0.15, window=5)
    for k in range(60):
        place.update((2.0 + 0.001 * k, 0.0), (0.0, 0.0), 0.1 * k)
    assert place.xy[0] == pytest.approx(2.0 + 0.001 * 59, abs=0.005)
