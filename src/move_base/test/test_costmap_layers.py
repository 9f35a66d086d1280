"""Costmap layers against hand computations (plain pytest, no ROS).

Reference numbers are worked out by hand in the comments (distances in cells * resolution,
inflation cost = int(252 * exp(-10 * (d - 0.17))) for the seed's padded footprint).
"""

import math

import numpy as np
import pytest
from move_base.costmap_2d import FREE_SPACE, INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D
from move_base.footprint import inscribed_radius, pad_footprint, parse_footprint
from move_base.layers import (
    InflationLayer,
    LayeredCostmap,
    ObservationSource,
    ObstacleLayer,
    StaticLayer,
    bresenham_cells,
    footprint_cost,
    inflation_cost,
)

pytestmark = pytest.mark.unit

SEED_FOOTPRINT = [[-0.16, -0.16], [-0.16, 0.16], [0.19, 0.16], [0.24, 0.0], [0.19, -0.16]]
PADDED = pad_footprint(parse_footprint(SEED_FOOTPRINT), 0.01)


def line_iterator_reference(x0, y0, x1, y1):
    """base_local_planner's LineIterator, step by step (the reference for the vectorised one)."""
    dx, dy = abs(x1 - x0), abs(y1 - y0)
    xinc1 = xinc2 = 1 if x1 >= x0 else -1
    yinc1 = yinc2 = 1 if y1 >= y0 else -1
    if dx >= dy:
        xinc1, yinc2, den, num, numadd, numpixels = 0, 0, dx, dx // 2, dy, dx
    else:
        xinc2, yinc1, den, num, numadd, numpixels = 0, 0, dy, dy // 2, dx, dy
    x, y, cells = x0, y0, []
    for _ in range(numpixels + 1):
        cells.append((x, y))
        num += numadd
        if num >= den:
            num -= den
            x += xinc1
            y += yinc1
        x += xinc2
        y += yinc2
    return cells


# --- rasterisation -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "line",
    [(0, 0, 7, 3), (0, 0, 3, 7), (5, 5, -2, 1), (3, 4, 3, 4), (0, 0, 0, -6), (10, 2, 1, 9), (-3, -4, 8, -1)],
)
def test_bresenham_matches_line_iterator(line):
    idx, x, y = bresenham_cells(*line)
    assert list(zip(x.tolist(), y.tolist(), strict=True)) == line_iterator_reference(*line)
    assert (idx == 0).all()


def test_bresenham_many_lines_and_end_cell_left_out():
    idx, x, y = bresenham_cells([0, 0], [0, 0], [4, 0], [1, 3], include_end=[False, True])
    first = list(zip(x[idx == 0].tolist(), y[idx == 0].tolist(), strict=True))
    second = list(zip(x[idx == 1].tolist(), y[idx == 1].tolist(), strict=True))
    assert first == line_iterator_reference(0, 0, 4, 1)[:-1]  # (4, 1) left out
    assert first == [(0, 0), (1, 0), (2, 1), (3, 1)]
    assert second == line_iterator_reference(0, 0, 0, 3)


# --- inflation ---------------------------------------------------------------------------------
def test_seed_inscribed_radius_is_the_padded_side():
    # padded footprint: sides at y = +-0.17 and x = -0.17; the nose edges are 0.24 m away
    assert inscribed_radius(PADDED) == pytest.approx(0.17)


@pytest.mark.parametrize(
    ("d", "cost"),
    [
        (0.0, 254),
        (0.05, 253),
        (0.15, 253),
        (0.17, 253),  # inclusive
        (0.2, 186),  # 252 * exp(-0.3) = 186.69
        (math.sqrt(13) * 0.05, 227),  # 0.18028 m: 252 * exp(-0.10278) = 227.39
        (0.3, 68),  # 252 * exp(-1.3) = 68.68
        (0.4, 25),  # 252 * exp(-2.3) = 25.27
    ],
)
def test_inflation_cost_formula(d, cost):
    assert inflation_cost(d, 0.17, 10.0) == cost


def single_obstacle_grid(resolution, size=41):
    grid = Costmap2D(size, size, resolution)
    grid.costs[20, 20] = LETHAL_OBSTACLE
    return grid


@pytest.mark.parametrize(
    ("dx", "dy", "cost"),
    [
        (0, 0, 254),
        (1, 0, 253),
        (3, 0, 253),  # 0.15 m
        (2, 2, 253),  # 0.1414 m
        (4, 0, 186),  # 0.20 m
        (3, 2, 227),  # 0.1803 m
        (0, -6, 68),  # 0.30 m
        (-4, -4, 81),  # 0.2828 m: 252 * exp(-1.1284) = 81.53
        (8, 0, 25),  # 0.40 m, the inflation radius (8 cells)
        (6, 6, 0),  # 0.4243 m > 8 cells: untouched
        (9, 0, 0),
    ],
)
def test_inflation_of_one_lethal_cell_at_5cm(dx, dy, cost):
    grid = single_obstacle_grid(0.05)
    InflationLayer(0.17, 0.40, 10.0).update_costs(grid)
    assert grid.costs[20 + dy, 20 + dx] == cost


def test_inflation_radius_is_rounded_up_to_whole_cells_like_ros():
    # 0.55 m at 0.1 m: ceil(5.5) = 6 cells, so 0.6 m still inflated: 252 * exp(-10 * (0.6 - 0.17)) = 3.43
    grid = single_obstacle_grid(0.1)
    InflationLayer(0.17, 0.55, 10.0).update_costs(grid)
    assert grid.costs[20, 26] == 3
    assert grid.costs[20, 27] == 0
    assert grid.costs[20, 25] == 9  # 0.5 m: 9.29


def test_inflation_keeps_higher_costs_and_unknown_rules():
    grid = single_obstacle_grid(0.05)
    grid.costs[20, 24] = 200  # 0.20 m: inflated 186 < 200 stays
    grid.costs[20, 26] = 10  # 0.30 m: 68 > 10 wins
    grid.costs[20, 22] = NO_INFORMATION  # 0.10 m, inside the inscribed radius: becomes 253
    grid.costs[20, 16] = NO_INFORMATION  # 0.20 m, outside it: stays unknown
    grid.costs[10, 10] = NO_INFORMATION  # far away: stays unknown
    InflationLayer(0.17, 0.40, 10.0).update_costs(grid)
    assert grid.costs[20, 24] == 200
    assert grid.costs[20, 26] == 68
    assert grid.costs[20, 22] == INSCRIBED_INFLATED_OBSTACLE
    assert grid.costs[20, 16] == NO_INFORMATION
    assert grid.costs[10, 10] == NO_INFORMATION


def test_inflation_uses_the_nearest_obstacle():
    grid = Costmap2D(30, 5, 0.05)
    grid.costs[2, 5] = LETHAL_OBSTACLE
    grid.costs[2, 13] = LETHAL_OBSTACLE
    InflationLayer(0.17, 0.40, 10.0).update_costs(grid)
    # cell 9 is 4 cells from both: 186; cell 10 is 3 from the second: 253
    assert grid.costs[2, 9] == 186
    assert grid.costs[2, 10] == 253
    # lethal/inscribed bands along the row
    assert (grid.costs[2, 2:9] == [253, 253, 253, 254, 253, 253, 253]).all()


# --- static layer ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("track_unknown", "expected"),
    [(False, [0, 0, 0, 0, 254, 254]), (True, [255, 0, 0, 0, 254, 254])],
)
def test_static_layer_is_trinary(track_unknown, expected):
    layer = StaticLayer(lethal_cost_threshold=100, track_unknown_space=track_unknown)
    layer.set_map([-1, 0, 50, 99, 100, -2], 3, 2, 0.05, -1.0, -2.0)
    assert layer.grid.costs.ravel().tolist() == expected
    assert (layer.grid.origin_x, layer.grid.origin_y, layer.grid.resolution) == (-1.0, -2.0, 0.05)


def test_static_layer_threshold():
    layer = StaticLayer(lethal_cost_threshold=65)
    layer.set_map([64, 65, 100], 3, 1, 0.1, 0.0, 0.0)
    assert layer.grid.costs.ravel().tolist() == [0, 254, 254]


def test_global_costmap_takes_the_static_maps_geometry():
    lc = LayeredCostmap(200, 200, 0.05, footprint=PADDED, static_map=True, inflation_radius=0.4)
    assert not lc.has_map()
    data = np.zeros((4, 6), dtype=np.int8)
    data[1, 2] = 100
    lc.set_static_map(data.ravel(), 6, 4, 0.1, -0.3, -0.2)
    assert lc.has_map()
    c = lc.costmap
    assert (c.size_x, c.size_y, c.resolution, c.origin_x, c.origin_y) == (6, 4, 0.1, -0.3, -0.2)
    assert lc.obstacles.grid.costs.shape == (4, 6)
    lc.update(0.0, 0.0)
    assert c.costs[1, 2] == LETHAL_OBSTACLE
    assert c.costs[1, 3] == 253  # 0.1 m <= 0.17
    assert c.costs[1, 4] == 186  # 0.2 m: 252 * exp(-0.3) = 186.69
    assert c.costs[1, 0] == 186
    assert c.costs[3, 2] == 186


# --- obstacle layer ----------------------------------------------------------------------------
def obstacle_layer(**kw):
    source = ObservationSource("scan", marking=True, clearing=True, **kw)
    layer = ObstacleLayer([source])
    layer.match_size(Costmap2D(60, 40, 0.1))  # 6 x 4 m, origin (0, 0)
    return layer


ORIGIN = np.array([0.55, 2.05, 0.3])  # sensor in cell (5, 20)


def test_real_return_marks_its_cell_and_clears_before_it():
    layer = obstacle_layer()
    layer.grid.costs[20, 5:26] = LETHAL_OBSTACLE  # stale obstacles along the beam
    layer.add_observation("scan", ORIGIN, [[2.05, 2.05, 0.3]])  # return in cell (20, 20)
    layer.update()
    row = layer.grid.costs[20]
    assert (row[5:20] == FREE_SPACE).all()
    assert row[20] == LETHAL_OBSTACLE
    assert (row[21:26] == LETHAL_OBSTACLE).all()  # behind the return: not touched


def test_max_range_ray_clears_through_a_marked_cell_up_to_raytrace_range():
    layer = obstacle_layer()
    layer.add_observation("scan", ORIGIN, [[1.55, 2.05, 0.3]])
    layer.update()
    assert layer.grid.costs[20, 15] == LETHAL_OBSTACLE
    layer.grid.costs[20, 36] = LETHAL_OBSTACLE
    # next scan: nothing seen along +x (a reading at range_max, or inf): a 3.0 m clearing ray
    layer.add_observation("scan", ORIGIN, np.zeros((0, 3)), free_ends=[[9.0, 2.05, 0.3]])
    layer.update()
    row = layer.grid.costs[20]
    assert row[15] == FREE_SPACE
    assert (row[5:36] == FREE_SPACE).all()  # 0.55 + 3.0 = 3.55 m: cell 35 cleared too
    assert row[36] == LETHAL_OBSTACLE  # beyond raytrace_range


def test_a_long_return_is_cut_at_raytrace_range_and_does_not_mark():
    layer = obstacle_layer()
    layer.grid.costs[20, 30:45] = LETHAL_OBSTACLE
    layer.add_observation("scan", ORIGIN, [[4.55, 2.05, 0.3]])  # 4.0 m: > obstacle_range 2.5, > raytrace 3.0
    layer.update()
    row = layer.grid.costs[20]
    assert (row[30:36] == FREE_SPACE).all()  # cleared up to 3.55 m, end cell included (cut)
    assert (row[36:45] == LETHAL_OBSTACLE).all()
    assert row[45] == FREE_SPACE  # the return at cell 45 did not mark


def test_diagonal_rays_clear_the_bresenham_cells():
    layer = obstacle_layer()
    layer.grid.costs[...] = LETHAL_OBSTACLE
    end = (1.75, 2.95)  # cell (17, 29) from (5, 20)
    layer.add_observation("scan", ORIGIN, [[*end, 0.3]])
    layer.update()
    free = set(zip(*np.nonzero(layer.grid.costs == FREE_SPACE)[::-1], strict=True))
    expected = set(line_iterator_reference(5, 20, 17, 29)[:-1])
    assert free == expected
    assert layer.grid.costs[29, 17] == LETHAL_OBSTACLE


@pytest.mark.parametrize(
    ("point", "marked"),
    [
        ((2.95, 2.05, 0.3), True),  # 2.4 m
        ((3.15, 2.05, 0.3), False),  # 2.6 m > obstacle_range
        ((2.05, 2.05, 2.5), False),  # above max_obstacle_height 2.0
        ((2.05, 2.05, -0.1), False),  # below min_obstacle_height 0.0
        ((2.05, 2.05, 2.0), True),  # limits inclusive
    ],
)
def test_obstacle_range_and_height_limits(point, marked):
    layer = obstacle_layer()
    layer.add_observation("scan", ORIGIN, [point])
    layer.update()
    cell = layer.grid.world_to_map(point[0], point[1])
    assert (layer.grid.costs[cell[1], cell[0]] == LETHAL_OBSTACLE) == marked


def test_obstacle_range_is_3d():
    # 2.4 m in the plane but the point is 1.0 m below the sensor: 2.6 m away, not marked
    layer = obstacle_layer(min_obstacle_height=-2.0)
    layer.add_observation("scan", ORIGIN, [[2.95, 2.05, -0.7]])
    layer.update()
    assert layer.grid.costs[20, 29] == FREE_SPACE


def test_clear_all_before_marking_any():
    source_a = ObservationSource("a", marking=True, clearing=False)
    source_b = ObservationSource("b", marking=False, clearing=True)
    layer = ObstacleLayer([source_a, source_b])
    layer.match_size(Costmap2D(60, 40, 0.1))
    layer.add_observation("a", ORIGIN, [[1.55, 2.05, 0.3]])  # marks (20, 15)
    layer.add_observation("b", ORIGIN, [[3.05, 2.05, 0.3]])  # its ray passes (20, 15)
    layer.update()
    assert layer.grid.costs[20, 15] == LETHAL_OBSTACLE
    assert layer.grid.costs[20, 25] == FREE_SPACE  # b does not mark


def test_persistence_and_expected_update_rate():
    src = ObservationSource("scan", observation_persistence=1.0, expected_update_rate=0.5)
    layer = ObstacleLayer([src], now=0.0)
    layer.match_size(Costmap2D(60, 40, 0.1))
    assert layer.is_current(0.4)
    assert layer.stale_sources(0.6) == ["scan"]
    layer.add_observation("scan", ORIGIN, [[1.05, 2.05, 0.3]], stamp=1.0, now=1.0)
    layer.add_observation("scan", ORIGIN, [[1.55, 2.05, 0.3]], stamp=1.8, now=1.8)
    assert len(layer.buffers["scan"].observations) == 2
    layer.add_observation("scan", ORIGIN, [[2.05, 2.05, 0.3]], stamp=2.5, now=2.5)
    assert [o.stamp for o in layer.buffers["scan"].observations] == [1.8, 2.5]  # 1.0 older than 1 s
    assert layer.is_current(2.9)
    assert not layer.is_current(3.1)
    latest = ObstacleLayer([ObservationSource("scan")])
    for t in (1.0, 2.0):
        latest.add_observation("scan", ORIGIN, [[1.05, 2.05, 0.3]], stamp=t)
    assert len(latest.buffers["scan"].observations) == 1
    assert latest.is_current(1000.0)  # expected_update_rate 0: never stale


# --- rolling window ----------------------------------------------------------------------------
def rolling(track_unknown=False):
    src = ObservationSource("scan", marking=True, clearing=False)
    return LayeredCostmap(
        100,
        100,
        0.1,
        footprint=PADDED,
        rolling_window=True,
        static_map=False,
        sources=[src],
        inflation_radius=0.4,
        track_unknown_space=track_unknown,
    )


def test_rolling_window_recentres_on_whole_cells_and_keeps_obstacles():
    lc = rolling()
    lc.update(0.0, 0.0)
    assert (lc.costmap.origin_x, lc.costmap.origin_y) == pytest.approx((-5.0, -5.0))
    lc.obstacles.add_observation("scan", [0.0, 0.0, 0.3], [[1.05, 0.55, 0.3]])
    lc.update(0.0, 0.0)
    assert lc.costmap.cost_at(1.05, 0.55) == LETHAL_OBSTACLE
    lc.obstacles.buffers["scan"].observations.clear()  # no new readings
    lc.update(0.73, -0.26)  # shift by int(0.73 / 0.1) = 7, int(-0.26 / 0.1) = -2 cells
    assert (lc.costmap.origin_x, lc.costmap.origin_y) == pytest.approx((-4.3, -5.2))
    assert lc.obstacles.grid.origin_x == pytest.approx(-4.3)
    assert lc.costmap.cost_at(1.05, 0.55) == LETHAL_OBSTACLE
    assert lc.costmap.cost_at(1.05 + 0.1, 0.55) == 253
    assert int((lc.costmap.costs == LETHAL_OBSTACLE).sum()) == 1
    lc.update(20.0, 20.0)  # moved off: the obstacle is gone
    assert not (lc.costmap.costs == LETHAL_OBSTACLE).any()


def test_rolling_window_new_cells_are_unknown_when_tracking_unknown():
    lc = rolling(track_unknown=True)
    lc.update(0.0, 0.0)
    assert (lc.costmap.costs == NO_INFORMATION).all()


def test_rolling_window_copies_the_overlapping_static_map():
    lc = LayeredCostmap(20, 20, 0.1, footprint=PADDED, rolling_window=True, static_map=True, inflation_radius=0.1)
    data = np.zeros((10, 10), dtype=np.int8)  # 1 x 1 m map at 0.1 m, origin (0, 0)
    data[5, 5] = 100
    lc.set_static_map(data.ravel(), 10, 10, 0.1, 0.0, 0.0)
    assert lc.costmap.size_x == 20  # rolling: geometry kept
    lc.update(1.0, 1.0)  # window [0, 2] x [0, 2]
    assert lc.costmap.origin_x == pytest.approx(0.0)
    assert lc.costmap.cost_at(0.55, 0.55) == LETHAL_OBSTACLE
    assert int((lc.costmap.costs == LETHAL_OBSTACLE).sum()) == 1


def test_rolling_window_places_a_static_map_of_another_frame_by_its_pose():
    # a local costmap in odom with the map in map: the map frame sits at (0.3, -0.2) in odom,
    # turned by 0.1 rad; one lethal map cell, centre (0.525, 0.525) in map
    lc = LayeredCostmap(40, 40, 0.05, footprint=PADDED, rolling_window=True, static_map=True, inflation_radius=0.0)
    data = np.zeros((20, 20), dtype=np.int8)
    data[10, 10] = 100
    lc.set_static_map(data.ravel(), 20, 20, 0.05, 0.0, 0.0, "map", needs_pose=True)
    lc.update(0.8, 0.5)
    assert not (lc.costmap.costs == LETHAL_OBSTACLE).any()  # no pose yet: nothing written
    lc.set_static_pose((0.3, -0.2, 0.1))
    lc.update(0.8, 0.5)
    c, s = math.cos(0.1), math.sin(0.1)
    ox, oy = 0.3 + c * 0.525 - s * 0.525, -0.2 + s * 0.525 + c * 0.525  # (0.7698, 0.3748) in odom
    assert lc.costmap.cost_at(ox, oy) == LETHAL_OBSTACLE
    assert lc.costmap.cost_at(0.525, 0.525) == FREE_SPACE  # where it would be with the frames mixed up
    lethal = np.argwhere(lc.costmap.costs == LETHAL_OBSTACLE)
    assert 1 <= len(lethal) <= 4  # the cells the turned map cell overlaps
    wx, wy = lc.costmap.map_to_world(lethal[:, 1], lethal[:, 0])
    assert np.all(np.hypot(wx - ox, wy - oy) < 0.05 * math.sqrt(2))


def test_coarser_turned_window_keeps_a_thin_static_wall_closed():
    # a wall one 0.05 m cell thick seen through a 0.1 m window turned by 0.05 rad, off by half a
    # cell: sampling only the cell centres lets the laser-invisible edge leak through
    lc = LayeredCostmap(30, 30, 0.1, footprint=PADDED, rolling_window=True, static_map=True, inflation_radius=0.0)
    data = np.zeros((60, 60), dtype=np.int8)
    data[:, 30] = 100  # x 1.50 .. 1.55 m in map
    lc.set_static_map(data.ravel(), 60, 60, 0.05, 0.0, 0.0, "map", needs_pose=True)
    lc.set_static_pose((0.05, 0.0, 0.05))
    lc.update(1.5, 1.5)
    rows = lc.costmap.costs == LETHAL_OBSTACLE
    assert rows.any(axis=1).all()  # every row of the window crosses the wall
    assert rows.sum(axis=1).max() <= 3


def test_rolling_window_frees_the_static_cells_under_the_robot_only():
    # a map wall that amcl's error has moved under the robot's back edge: the robot must still
    # be able to drive off it, and must not drive further into it
    lc = LayeredCostmap(40, 40, 0.05, footprint=PADDED, rolling_window=True, static_map=True, inflation_radius=0.3)
    data = np.zeros((40, 40), dtype=np.int8)
    data[:, 14:19] = 100  # x 0.70 .. 0.95 m
    lc.set_static_map(data.ravel(), 40, 40, 0.05, 0.0, 0.0)
    lc.update(1.0, 1.0, 0.0)  # the padded footprint's back edge at x 0.83 m
    assert lc.costmap.cost_at(0.875, 1.0) < LETHAL_OBSTACLE  # under the robot
    assert lc.costmap.cost_at(0.875, 1.3) == LETHAL_OBSTACLE  # beside it
    assert lc.costmap.cost_at(0.775, 1.0) == LETHAL_OBSTACLE  # behind it
    assert lc.footprint_cost(1.05, 1.0, 0.0) >= 0  # it can move forward, off the wall
    assert lc.footprint_cost(0.95, 1.0, 0.0) == -1.0  # not back into it
    lc.clear_outside(1.0, 1.0, 1.0)  # a recovery rebuilds the grid: the robot's cells stay free
    assert lc.costmap.cost_at(0.875, 1.0) < LETHAL_OBSTACLE
    lc.update(1.0, 1.0)  # no heading: nothing is freed
    assert lc.costmap.cost_at(0.875, 1.0) == LETHAL_OBSTACLE


def test_static_map_of_another_frame_needs_a_rolling_window():
    lc = LayeredCostmap(20, 20, 0.1, footprint=PADDED, static_map=True)
    with pytest.raises(ValueError, match="rolling window"):
        lc.set_static_map(np.zeros(100, dtype=np.int8), 10, 10, 0.1, 0.0, 0.0, "map", needs_pose=True)


# --- recoveries --------------------------------------------------------------------------------
def test_clear_outside_keeps_the_window_and_resets_the_rest():
    src = ObservationSource("scan")
    lc = LayeredCostmap(40, 40, 0.1, footprint=PADDED, static_map=True, sources=[src], inflation_radius=0.1)
    data = np.zeros((40, 40), dtype=np.int8)
    data[0, 0] = 100  # a static obstacle far from the robot survives the reset
    lc.set_static_map(data.ravel(), 40, 40, 0.1, 0.0, 0.0)
    lc.obstacles.grid.costs[...] = LETHAL_OBSTACLE
    lc.clear_outside(2.0, 2.0, 1.0)
    # corners: int((1.5 - 0) / 0.1) = 15, int(2.5 / 0.1) = 25; kept cells 16..24
    kept = lc.obstacles.grid.costs == LETHAL_OBSTACLE
    expected = np.zeros((40, 40), dtype=bool)
    expected[16:25, 16:25] = True
    assert (kept == expected).all()
    assert (lc.obstacles.grid.costs[~expected] == NO_INFORMATION).all()
    lc.update(2.0, 2.0)
    assert lc.costmap.costs[0, 0] == LETHAL_OBSTACLE
    assert lc.costmap.costs[20, 20] == LETHAL_OBSTACLE
    assert lc.costmap.costs[30, 30] == FREE_SPACE  # obstacle-layer unknown: master shows the map


def test_reset_layers_forgets_obstacles_keeps_the_map():
    lc = LayeredCostmap(40, 40, 0.1, footprint=PADDED, sources=[ObservationSource("scan")], inflation_radius=0.1)
    data = np.zeros((40, 40), dtype=np.int8)
    data[3, 3] = 100
    lc.set_static_map(data.ravel(), 40, 40, 0.1, 0.0, 0.0)
    lc.obstacles.grid.costs[20, 20] = LETHAL_OBSTACLE
    lc.reset_layers()
    assert lc.costmap.costs[20, 20] == FREE_SPACE
    assert lc.costmap.costs[3, 3] == LETHAL_OBSTACLE


def test_clear_unknown_around():
    lc = LayeredCostmap(40, 40, 0.1, footprint=PADDED, track_unknown_space=True, inflation_radius=0.1)
    lc.set_static_map(np.full(1600, -1, dtype=np.int8), 40, 40, 0.1, 0.0, 0.0)
    lc.update(2.0, 2.0)
    assert (lc.costmap.costs == NO_INFORMATION).all()
    lc.clear_unknown_around(2.0, 2.0, 0.4)  # centres within [1.8, 2.2]: cells 18..21
    free = lc.costmap.costs == FREE_SPACE
    expected = np.zeros((40, 40), dtype=bool)
    expected[18:22, 18:22] = True
    assert (free == expected).all()
    lc.update(2.0, 2.0)  # lasts: held by the obstacle layer
    assert ((lc.costmap.costs == FREE_SPACE) == expected).all()


# --- footprint cost ----------------------------------------------------------------------------
SQUARE = np.array([[-0.2, -0.2], [-0.2, 0.2], [0.2, 0.2], [0.2, -0.2]])


def test_footprint_cost_free_lethal_unknown_off_map():
    grid = Costmap2D(40, 40, 0.1)
    pts = SQUARE + np.array([2.0, 2.0])
    assert footprint_cost(grid, pts, (2.0, 2.0)) == 0.0
    grid.costs[20, 20] = LETHAL_OBSTACLE  # inside, not on the outline
    assert footprint_cost(grid, pts, (2.0, 2.0)) == 0.0
    grid.costs[22, 20] = 100  # on the top edge (y = 2.2 -> row 22)
    assert footprint_cost(grid, pts, (2.0, 2.0)) == 100.0
    grid.costs[18, 21] = LETHAL_OBSTACLE  # on the bottom edge (y = 1.8 -> row 18)
    assert footprint_cost(grid, pts, (2.0, 2.0)) == -1.0
    grid.costs[18, 21] = NO_INFORMATION
    assert footprint_cost(grid, pts, (2.0, 2.0)) == -2.0
    assert footprint_cost(grid, SQUARE + np.array([3.9, 2.0]), (3.9, 2.0)) == -3.0  # right side off the map
    assert footprint_cost(grid, SQUARE + np.array([5.0, 2.0]), (5.0, 2.0)) == -3.0  # centre off the map


def test_footprint_cost_first_verdict_in_edge_order():
    grid = Costmap2D(40, 40, 0.1)
    pts = SQUARE + np.array([2.0, 2.0])
    grid.costs[19, 18] = NO_INFORMATION  # first edge (left side, walked upwards)
    grid.costs[22, 20] = LETHAL_OBSTACLE  # second edge (top)
    assert footprint_cost(grid, pts) == -2.0


def test_layered_footprint_cost_rotates_the_footprint():
    lc = LayeredCostmap(40, 40, 0.1, footprint=SQUARE, static_map=False, inflation_radius=0.0)
    lc.costmap.costs[20, 22] = LETHAL_OBSTACLE  # (2.25, 2.05): on the right side at yaw 0 ...
    assert lc.footprint_cost(2.05, 2.05, 0.0) == -1.0
    # ... turned by 45 degrees the outline runs from the vertex in cell (23, 20) diagonally, missing it
    assert lc.footprint_cost(2.05, 2.05, math.pi / 4) == 0.0


def test_polygon_cells_cover_the_inside_and_the_outline():
    from move_base.layers import polygon_cells

    grid = Costmap2D(20, 20, 0.1)
    square = [[0.5, 0.5], [1.45, 0.5], [1.45, 1.45], [0.5, 1.45]]  # cells 5..14 each way
    mx, my = polygon_cells(grid, square)
    covered = np.zeros((20, 20), bool)
    covered[my, mx] = True
    assert covered[5:15, 5:15].all()
    assert covered.sum() == 100
    assert polygon_cells(grid, [[5, 5], [6, 5], [6, 6]])[0].size == 0  # off the grid


def test_update_clears_marks_under_the_robot_footprint_only():
    """A stale mark under the robot (costmap_2d clears the footprint) would leave the robot 'inside
    an obstacle' and every plan from it failing; a mark just outside the footprint stays."""
    lc = rolling()
    lc.update(2.0, 2.0, 0.0)
    g = lc.obstacles.grid
    under = g.world_to_map(2.1, 2.05)
    outside = g.world_to_map(2.45, 2.05)  # 0.45 m ahead: beyond the footprint's 0.25 m nose
    for mx, my in (under, outside):
        g.costs[my, mx] = LETHAL_OBSTACLE
    lc.update(2.0, 2.0, 0.0)
    assert g.costs[under[1], under[0]] == FREE_SPACE
    assert g.costs[outside[1], outside[0]] == LETHAL_OBSTACLE
    assert lc.costmap.cost_at(2.45, 2.05) == LETHAL_OBSTACLE
    lc.update(2.0, 2.0)  # without a heading nothing is cleared (the old call)
    assert g.costs[outside[1], outside[0]] == LETHAL_OBSTACLE
