"""The laser's geometry from tf and which readings count."""

import math

import numpy as np
import pytest
from gmapping.laser import LaserGeometry, LaserNotPlanar, usable_ranges

from florence_common import pose
from florence_harness import laser_scenes

pytestmark = pytest.mark.unit


def test_upside_down_laser_mirrors_the_beams():
    """The Florence Hokuyo (rpy pi 0 0): a beam at +a in its frame points to -a on the base."""
    up = LaserGeometry.from_transform(laser_scenes.UPRIGHT, -1.0, 0.5, 5)
    down = LaserGeometry.from_transform(laser_scenes.UPSIDE_DOWN, -1.0, 0.5, 5)
    assert not up.upside_down and down.upside_down
    np.testing.assert_allclose(up.bearings, [-1.0, -0.5, 0.0, 0.5, 1.0], atol=1e-12)
    np.testing.assert_allclose(down.bearings, [1.0, 0.5, 0.0, -0.5, -1.0], atol=1e-12)
    assert (down.x, down.y) == pytest.approx((0.06, 0.0))


def test_tilted_laser_is_refused():
    tilted = pose.transform_matrix((0.0, 0.0, 0.2), tuple(pose.Rotation.from_euler("y", 0.1).as_quat()))
    with pytest.raises(LaserNotPlanar, match="planar"):
        LaserGeometry.from_transform(tilted, -1.0, 0.5, 5)
    slight = pose.transform_matrix((0.0, 0.0, 0.2), tuple(pose.Rotation.from_euler("y", 0.01).as_quat()))
    LaserGeometry.from_transform(slight, -1.0, 0.5, 5)  # within slam_gmapping's tolerance (cos > 0.999)


def test_bad_readings_become_no_reading():
    r = usable_ranges([1.0, math.nan, math.inf, -math.inf, 0.01, 5.0, 5.595, 0.0], 0.02, 5.59)
    assert r[0] == 1.0 and r[5] == 5.0
    assert np.isinf(r[[1, 2, 3, 4, 6, 7]]).all() and (r > 0).all()
