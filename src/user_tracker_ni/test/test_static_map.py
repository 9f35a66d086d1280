"""The map check: walls, door frames and poles are thin static structure nobody stands in; a
sofa-sized block is not (people sit on it)."""

import numpy as np
import pytest
from user_tracker_ni.static_map import StaticMap, StaticMapParams

pytestmark = pytest.mark.unit

RES = 0.05


def grid():
    """A 4 x 4 m map (origin (-1, -1)): a wall along x = 0, a 4 cm pole at (1.5, 1.5), a 0.9 x 2 m
    sofa from (1.0, -0.8)."""
    g = np.zeros((80, 80), np.int8)

    def cells(x0, x1, y0, y1):
        return slice(round((y0 + 1) / RES), round((y1 + 1) / RES)), slice(round((x0 + 1) / RES), round((x1 + 1) / RES))

    g[cells(-0.05, 0.05, -1.0, 3.0)] = 100
    g[cells(1.45, 1.55, 1.45, 1.55)] = 100
    g[cells(1.0, 3.0, -0.8, 0.1)] = 100
    return g


def test_thin_structure_is_nobody_thick_furniture_may_hold_people():
    m = StaticMap(grid(), RES, (-1.0, -1.0, 0.0))
    on = m.on_structure([[0.0, 1.0], [0.08, 1.0], [0.5, 1.0], [1.5, 1.5], [2.0, -0.35], [1.0, -0.35], [9.0, 9.0]])
    # the wall, beside it, clear floor, the pole, on the sofa, the sofa's edge, off the map
    assert on.tolist() == [True, True, False, True, False, False, False]


def test_the_map_may_be_turned():
    g = np.zeros((40, 40), np.int8)
    g[20:22, 10] = 100  # a short thin wall, in grid cells
    m = StaticMap(g, RES, (1.0, 2.0, np.pi / 2))
    # cell (row 20, column 10) is 0.5 m along the map's x (now the world's +y) and 1.0 m along its y
    assert m.on_structure([[1.0 - 1.025, 2.0 + 0.525]])[0]
    assert not m.on_structure([[1.0 + 1.0, 2.0 + 0.5]])[0]


def test_bad_maps_are_refused():
    with pytest.raises(ValueError, match="not a usable grid"):
        StaticMap(np.zeros((0, 0)), RES, (0, 0, 0))
    with pytest.raises(ValueError, match="clearance"):
        StaticMapParams(clearance=-1.0).validate()
