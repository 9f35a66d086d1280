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
