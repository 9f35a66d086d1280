"""Occupancy grids in the map frame: cells, blocked points, clearance."""

import math

import numpy as np
import pytest

from florence_common.grid import Grid

pytestmark = pytest.mark.unit


def test_cells_blocked_and_clearance():
    data = np.zeros((20, 40), dtype=int)  # 2 x 1 m at 5 cm, origin (-1, 0)
    data[:, 20] = 100  # a wall at x = 0.0 .. 0.05
    data[0, 0] = -1  # unknown
    grid = Grid(data, (-1.0, 0.0, 0.0), 0.05)
    pts = [[-0.5, 0.5], [0.02, 0.5], [-0.98, 0.02], [5.0, 0.5], [math.nan, 0.5]]
    assert list(grid.blocked_at(pts)) == [False, True, True, True, True]
    assert grid.clearance_at([[-0.5, 0.5]])[0] == pytest.approx(0.5, abs=0.05)
    assert grid.clearance_at([[5.0, 0.5]])[0] == 0.0


def test_a_turned_origin():
    data = np.zeros((10, 10), dtype=int)
    data[0, 9] = 100  # the cell at the origin's +x end of its first row
    grid = Grid(data, (1.0, 1.0, math.pi / 2), 0.1)  # the grid's +x points along the map's +y
    assert grid.blocked_at([[0.95, 1.95]])[0]  # cell (0, 9): 0.95 m along the map's +y, 0.05 m to its -x
    assert not grid.blocked_at([[0.95, 1.85]])[0] and not grid.blocked_at([[0.95, 1.05]])[0]
    assert grid.blocked_at([[1.05, 1.5]])[0]  # on the origin's other side: off the grid


def test_line_of_sight_per_segment_and_to_one_end():
    data = np.zeros((20, 40), dtype=int)  # 2 x 1 m at 5 cm, origin (-1, 0)
    data[:10, 20] = 100  # a wall at x = 0.0 .. 0.05, y 0 .. 0.5
    grid = Grid(data, (-1.0, 0.0, 0.0), 0.05)
    starts = [[-0.5, 0.2], [-0.5, 0.8], [-0.5, 0.2]]
    ends = [[0.5, 0.2], [0.5, 0.8], [-0.5, 0.9]]
    assert grid.line_of_sight(starts, ends).tolist() == [False, True, True]
    assert grid.line_of_sight(starts, (0.5, 0.6)).tolist() == [False, True, False]  # one end for all
    assert grid.line_of_sight([[-0.5, 0.2]], (-0.5, 0.2)).tolist() == [True]  # no length


def test_sight_matrix_is_line_of_sight_for_every_pair():
    rng = np.random.default_rng(3)
    data = np.zeros((40, 60), dtype=int)  # 3 x 2 m at 5 cm, turned origin
    data[10:30, 25:28] = 100
    data[5, 40:50] = 100
    data[0, 0] = -1
    grid = Grid(data, (0.5, -0.2, 0.3), 0.05)
    starts = rng.uniform([-1.0, -0.5], [3.5, 2.5], (30, 2))
    ends = rng.uniform([-1.0, -0.5], [3.5, 2.5], (25, 2))
    got = grid.sight_matrix(starts, ends)
    want = np.array([[grid.line_of_sight([a], b)[0] for b in ends] for a in starts])
    assert got.shape == (30, 25) and got.any() and not got.all()
    assert (got == want).all()


def test_sight_matrix_skips_the_end_and_leaves_out_long_pairs():
    data = np.zeros((20, 40), dtype=int)  # 2 x 1 m at 5 cm, origin (-1, 0)
    data[:, 20] = 100  # a wall at x = 0.0 .. 0.05
    grid = Grid(data, (-1.0, 0.0, 0.0), 0.05)
    starts = [[-0.5, 0.5]]
    ends = [[0.1, 0.5], [0.5, 0.5], [-0.2, 0.5]]  # just behind the wall, well behind it, before it
    assert grid.sight_matrix(starts, ends).tolist() == [[False, False, True]]
    # the last 0.15 m not looked at: the wall 0.05-0.1 m before the first end does not hide it
    assert grid.sight_matrix(starts, ends, skip_end=0.15).tolist() == [[True, False, True]]
    # 0.6, 1.0 and 0.3 m long: beyond max_length a pair is not seen, however clear
    assert grid.sight_matrix(starts, ends, skip_end=0.15, max_length=0.8).tolist() == [[True, False, True]]
    assert grid.sight_matrix(starts, ends, skip_end=0.15, max_length=0.5).tolist() == [[False, False, True]]
    # a point that is not finite sees nothing and is seen by nothing
    assert grid.sight_matrix([[math.nan, 0.5], [-0.5, 0.5]], [[-0.2, 0.5], [math.inf, 0.5]]).tolist() == \
        [[False, False], [True, False]]


def test_with_obstacles_adds_another_grids_blocked_cells():
    data = np.zeros((20, 40), dtype=int)  # 2 x 1 m at 5 cm, origin (-1, 0)
    data[:, 0] = 100
    grid = Grid(data, (-1.0, 0.0, 0.0), 0.05)
    keep = np.zeros((5, 5), dtype=int)  # a 0.5 m square of 0.1 m cells at (0, 0.2) .. (0.5, 0.7)
    keep[1:3, 1:3] = 100  # (0.1, 0.3) .. (0.3, 0.5)
    both = grid.with_obstacles(Grid(keep, (0.0, 0.2, 0.0), 0.1))
    assert type(both) is Grid and both.blocked.shape == grid.blocked.shape
    assert both.blocked_at([[0.2, 0.4], [-0.98, 0.5]]).tolist() == [True, True]
    assert both.blocked_at([[0.05, 0.4], [0.35, 0.4], [0.6, 0.4], [-0.5, 0.5]]).tolist() == [False] * 4
    assert int(both.blocked.sum()) == int(grid.blocked.sum()) + 16  # 4 cells of 0.1 m: 16 of 5 cm
    assert not grid.blocked_at([[0.2, 0.4]])[0]  # the grid itself is unchanged
