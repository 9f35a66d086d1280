"""The keep rule of filter_user_tracker."""

import math

import numpy as np
import pytest
from filter_user_tracker.stale import keep_mask

pytestmark = pytest.mark.unit


def test_near_stale_and_nan_users_are_dropped():
    positions = [(2.0, 0.0), (0.3, 0.1), (1.0, 1.0), (math.nan, 0.0)]
    last_seen = [10.0, 10.0, 9.0, 10.0]
    keep = keep_mask(positions, last_seen, (0.0, 0.0), now=10.0, zero_radius=0.5, stale_after=0.5)
    assert keep.tolist() == [True, False, False, False]


def test_without_a_camera_only_staleness_counts():
    keep = keep_mask([(0.1, 0.0), (3.0, 0.0)], [10.0, 8.0], None, now=10.0, zero_radius=0.5, stale_after=0.5)
    assert keep.tolist() == [True, False]


def test_no_users():
    assert keep_mask(np.zeros((0, 2)), [], (0.0, 0.0), 1.0, 0.5, 0.5).tolist() == []
