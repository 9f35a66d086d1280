"""Every particle's own hit map in one pool of copy-on-write patches."""

import math

import numpy as np
import pytest
from gmapping.laser import LaserGeometry, usable_ranges
from gmapping.particle_maps import PATCH, ParticleMaps

from florence_harness import laser_scenes

pytestmark = pytest.mark.unit

WORLD = laser_scenes.room()


def scan_at(pose):
    ranges, angle_min, inc = laser_scenes.scan(WORLD, pose)
    laser = LaserGeometry.from_transform(laser_scenes.UPSIDE_DOWN, angle_min, inc, len(ranges))
    return laser, usable_ranges(ranges, 0.02, 5.59)


def hits_at(maps, particle, x, y):
    hits, _, _, origin = maps.dense(particle)
    return hits[math.floor((y - origin[1]) / maps.delta), math.floor((x - origin[0]) / maps.delta)]


def test_hits_land_where_the_beams_end_with_their_mean():
    maps = ParticleMaps(1, 0.05)
    maps.cover(-1, -1, 7, 5)
    pose = (3.0, 1.5, 0.3)
    laser, ranges = scan_at(pose)
    maps.register(np.array([pose]), laser, ranges, 5.59)
    hits, mean_x, mean_y, origin = maps.dense(0)
    assert hits.sum() == np.count_nonzero(np.isfinite(ranges))
    # a cell's mean hit point lies in the cell, and that of a cell with one hit on a wall of the room
    cells = np.argwhere(hits > 0)
    xs, ys = mean_x[cells[:, 0], cells[:, 1]], mean_y[cells[:, 0], cells[:, 1]]
    centre_x, centre_y = origin[0] + (cells[:, 1] + 0.5) * 0.05, origin[1] + (cells[:, 0] + 0.5) * 0.05
    assert (np.abs(xs - centre_x) <= 0.025 + 1e-6).all() and (np.abs(ys - centre_y) <= 0.025 + 1e-6).all()
    single = hits[cells[:, 0], cells[:, 1]] == 1
    on_wall = [min(_distance_to_segment(x, y, seg) for seg in WORLD) for x, y in zip(xs[single], ys[single],
                                                                                       strict=True)]
    assert single.sum() > 100 and max(on_wall) < 1e-4


def _distance_to_segment(x, y, seg):
    p, a, b = np.array([x, y]), seg[:2], seg[2:]
    t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


def test_particles_share_patches_until_one_writes():
    maps = ParticleMaps(3, 0.05, capacity=8)
    maps.cover(-1, -1, 7, 5)
    laser, ranges = scan_at((3.0, 1.5, 0.0))
    maps.register(np.array([[3.0, 1.5, 0.0]]), laser, ranges, 5.59)
    maps.share(0)
    shared = maps.patches_in_use()
    assert (maps.refs[maps.refs > 0] == 3).all()
    before = [maps.dense(i)[0].copy() for i in range(3)]
    np.testing.assert_array_equal(before[0], before[2])
    # particle 1 alone sees another scan: it gets copies of the patches it writes, the others keep theirs
    laser2, ranges2 = scan_at((3.0, 1.5, math.pi))
    maps.register(np.array([[3.0, 1.5, math.pi]]), laser2, ranges2, 5.59, particles=[1])
    assert maps.patches_in_use() > shared
    np.testing.assert_array_equal(maps.dense(0)[0], before[0])
    np.testing.assert_array_equal(maps.dense(2)[0], before[2])
    assert maps.dense(1)[0].sum() == before[0].sum() + np.count_nonzero(np.isfinite(ranges2))
    # resampling: 0 and 2 become copies of 1; patches nobody uses go back to the pool
    maps.resample([1, 1, 1])
    for i in range(3):
        np.testing.assert_array_equal(maps.dense(i)[0], maps.dense(1)[0])
    assert maps.patches_in_use() == len(np.unique(maps.index[maps.index >= 0]))
    assert (maps.refs[np.unique(maps.index[maps.index >= 0])] == 3).all()


def test_growing_the_grid_and_the_pool_keeps_every_hit():
    maps = ParticleMaps(2, 0.05, capacity=1)
    maps.cover(2.0, 1.0, 3.0, 2.0)
    pose = (3.0, 1.5, 0.0)
    laser, ranges = scan_at(pose)
    maps.cover(-1, -1, 7, 5)  # grows towards negative coordinates: the index shifts
    maps.register(np.array([pose, pose]), laser, ranges, 5.59)
    assert maps.capacity > 1
    first = maps.dense(0)
    maps.cover(-20.0, -20.0, 20.0, 20.0)
    again = maps.dense(0)
    assert again[0].sum() == first[0].sum() == np.count_nonzero(np.isfinite(ranges))
    assert hits_at(maps, 0, 6.0 - 0.01, 1.5) > 0  # the east wall straight ahead
    assert maps.index.shape[1] * PATCH * 0.05 >= 40.0
