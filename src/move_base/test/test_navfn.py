"""Tests of move_base.navfn against independent references.

The reference is an 8-connected Dijkstra (heapq) over the navfn traversal costs, written here:
moving into a cell costs its traversal cost times the step length [cells] (1 or sqrt(2)). navfn's
interpolated wavefront approximates the cost-weighted Euclidean distance, which the 8-connected
metric overestimates by at most 8.2 % (at 22.5 deg), so navfn's potential and path cost must lie
a little below or near the Dijkstra figures, never far above them, and never below the straight
line weighted by the cheapest cost.
"""

import heapq
import math

import numpy as np
import pytest
from move_base.costmap_2d import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)
from move_base.navfn import NavfnPlanner, keep_current_plan, path_cost, plans_apart, translate_costs

pytestmark = pytest.mark.unit

RES = 0.05  # [m]
ORIGIN = (-1.0, 0.5)  # [m], not zero so world/map mix-ups show


# --- reference computations -----------------------------------------------------------------
def ref_traversal_cost(c, allow_unknown=True):
    """navfn.h / NavFn::setCostmap written out per value (COST_NEUTRAL 50, COST_FACTOR 3)."""
    if c == NO_INFORMATION:
        return 253 if allow_unknown else None
    if c >= INSCRIBED_INFLATED_OBSTACLE:
        return None
    return min(50 + 3 * c, 253)


def dijkstra8(trav, source):
    """8-connected Dijkstra over traversal costs ``trav[my, mx]`` (>= 254 blocked) from ``source``
    = (mx, my); cost of a move = cost of the entered cell * step length [cells]."""
    ny, nx = trav.shape
    dist = np.full((ny, nx), np.inf)
    prev = {}
    sx, sy = source
    dist[sy, sx] = 0.0
    heap = [(0.0, sx, sy)]
    steps = [(dx, dy, math.hypot(dx, dy)) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    while heap:
        d, x, y = heapq.heappop(heap)
        if d > dist[y, x]:
            continue
        for dx, dy, length in steps:
            u, v = x + dx, y + dy
            if not (0 <= u < nx and 0 <= v < ny) or trav[v, u] >= 254:
                continue
            nd = d + trav[v, u] * length
            if nd < dist[v, u]:
                dist[v, u] = nd
                prev[(u, v)] = (x, y)
                heapq.heappush(heap, (nd, u, v))
    return dist, prev


def ref_trav(costs, allow_unknown=True, robot_cell=None):
    """Reference traversal array: per-value table, outer ring and robot cell as navfn sets them."""
    table = {c: ref_traversal_cost(c, allow_unknown) for c in range(256)}
    trav = np.vectorize(lambda c: 254 if table[c] is None else table[c])(costs).astype(np.int64)
    trav[0, :] = trav[-1, :] = trav[:, 0] = trav[:, -1] = 254
    if robot_cell is not None:
        trav[robot_cell[1], robot_cell[0]] = 50
    return trav


def make_costmap(costs):
    cm = Costmap2D(costs.shape[1], costs.shape[0], RES, *ORIGIN)
    cm.costs[...] = costs
    return cm


def cell_center(mx, my):
    return ORIGIN[0] + (mx + 0.5) * RES, ORIGIN[1] + (my + 0.5) * RES


def path_cells(cm, poses, step=0.05):
    """Cells (mx, my) visited by the polyline, sampled every ``step`` cells."""
    pts = [poses[0, :2]]
    for a, b in zip(poses[:-1, :2], poses[1:, :2], strict=True):
        n = max(1, math.ceil(np.hypot(*(b - a)) / (step * RES)))
        t = np.linspace(0.0, 1.0, n + 1)[1:, None]
        pts.append(a + t * (b - a))
    pts = np.vstack(pts)
    mx, my, inside = cm.world_to_map(pts[:, 0], pts[:, 1])
    assert inside.all()
    return mx, my, pts


def weighted_length(cm, trav, poses):
    """Integral of traversal cost along the polyline [cost * cells]."""
    mx, my, pts = path_cells(cm, poses)
    seg = np.hypot(*np.diff(pts, axis=0).T) / RES
    return float(np.sum(trav[my[1:], mx[1:]] * seg))


def polyline_length(poses):
    return float(np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T)))


# --- synthetic grids ------------------------------------------------------------------------
def free_grid():
    return np.zeros((60, 70), dtype=np.uint8)


def random_grid(seed):
    """Lethal rectangles plus a cost halo decaying away from them (like inflation)."""
    rng = np.random.default_rng(seed)
    costs = np.zeros((80, 90), dtype=np.uint8)
    for _ in range(14):
        x, y = rng.integers(5, 80, 2)
        w, h = rng.integers(2, 10, 2)
        costs[y:y + h, x:x + w] = LETHAL_OBSTACLE
    from scipy.ndimage import distance_transform_edt

    d = distance_transform_edt(costs != LETHAL_OBSTACLE)
    halo = np.where(d <= 1.0, INSCRIBED_INFLATED_OBSTACLE, (252 * np.exp(-0.5 * (d - 1.0))).astype(int))
    costs = np.where(costs == LETHAL_OBSTACLE, LETHAL_OBSTACLE, halo).astype(np.uint8)
    costs[2:6, 2:6] = FREE_SPACE  # start corner
    costs[-6:-2, -6:-2] = FREE_SPACE  # goal corner
    return costs


def maze_grid():
    """Walls across the grid with gaps at alternating ends: a winding corridor."""
    costs = np.zeros((61, 61), dtype=np.uint8)
    for i, y in enumerate(range(10, 60, 10)):
        costs[y:y + 2, :] = LETHAL_OBSTACLE
        if i % 2 == 0:
            costs[y:y + 2, 52:58] = FREE_SPACE
        else:
            costs[y:y + 2, 3:9] = FREE_SPACE
    return costs


GRIDS = {
    "free": (free_grid, (5, 5), (62, 50)),
    "free_axis": (free_grid, (5, 30), (64, 30)),
    "random0": (lambda: random_grid(0), (3, 3), (86, 76)),
    "random1": (lambda: random_grid(1), (3, 3), (86, 76)),
    "random2": (lambda: random_grid(2), (3, 3), (86, 76)),
    "maze": (maze_grid, (5, 5), (5, 55)),
}


# --- tests ----------------------------------------------------------------------------------
def test_cost_translation_matches_navfn_table():
    costs = np.arange(256, dtype=np.uint8).reshape(16, 16)
    for allow in (True, False):
        got = translate_costs(costs, allow_unknown=allow)
        want = ref_trav(costs, allow_unknown=allow)
        assert np.array_equal(got, want), allow
    # spot values from navfn.h arithmetic: 0 -> 50, 10 -> 80, 67 -> 251, 68 -> 253 (capped)
    one_row = np.zeros((3, 8), dtype=np.uint8)
    one_row[1, 1:7] = [0, 10, 67, 68, 252, 253]
    assert translate_costs(one_row)[1, 1:7].tolist() == [50, 80, 251, 253, 253, 254]


@pytest.mark.parametrize("name", sorted(GRIDS))
def test_optimality_against_dijkstra(name):
    make, start_cell, goal_cell = GRIDS[name]
    costs = make()
    cm = make_costmap(costs)
    start = (*cell_center(*start_cell), 0.0)
    goal = (*cell_center(*goal_cell), 0.3)
    res = NavfnPlanner().make_plan(cm, start, goal)
    assert res.ok, res.reason

    trav = ref_trav(costs, robot_cell=start_cell)
    dist, _prev = dijkstra8(trav, start_cell)
    d8 = dist[goal_cell[1], goal_cell[0]]
    assert np.isfinite(d8)
    straight = math.hypot(goal_cell[0] - start_cell[0], goal_cell[1] - start_cell[1])  # [cells]

    # potential at the goal: weighted distance from the robot's cell
    pot = float(res.potential[goal_cell[1], goal_cell[0]])
    assert pot >= 0.99 * 50 * straight
    assert 0.95 * d8 <= pot <= 1.03 * d8, (pot, d8)

    # the path's cost-weighted length, and its geometric length
    wl = weighted_length(cm, trav, res.poses)
    assert 0.92 * d8 <= wl <= 1.01 * d8, (wl, d8)
    length = polyline_length(res.poses)
    assert length >= math.hypot(goal[0] - start[0], goal[1] - start[1]) - 1e-9


@pytest.mark.parametrize("name", ["free", "free_axis"])
def test_free_space_path_is_straight(name):
    make, start_cell, goal_cell = GRIDS[name]
    cm = make_costmap(make())
    start = np.array(cell_center(*start_cell))
    goal = np.array(cell_center(*goal_cell))
    res = NavfnPlanner().make_plan(cm, (*start, 0.0), (*goal, 0.0))
    assert res.ok
    # distance of every pose from the straight segment [m]
    u = (goal - start) / np.linalg.norm(goal - start)
    rel = res.poses[:, :2] - start
    off = np.abs(rel[:, 0] * u[1] - rel[:, 1] * u[0])
    assert off.max() < 1.5 * RES
    assert polyline_length(res.poses) <= 1.02 * np.linalg.norm(goal - start)
    # headings point along the segment (all but the goal pose)
    heading = math.atan2(u[1], u[0])
    err = np.angle(np.exp(1j * (res.poses[:-1, 2] - heading)))
    assert np.median(np.abs(err)) < 0.1


@pytest.mark.parametrize("name", sorted(GRIDS))
def test_path_avoids_obstacles_and_joins_start_to_goal(name):
    make, start_cell, goal_cell = GRIDS[name]
    costs = make()
    cm = make_costmap(costs)
    start = (*cell_center(*start_cell), 0.2)
    goal = (goal_center := cell_center(*goal_cell))[0] + 0.01, goal_center[1] - 0.02, -1.0
    res = NavfnPlanner().make_plan(cm, start, goal)
    assert res.ok, res.reason
    assert np.allclose(res.poses[0, :2], start[:2])
    assert np.allclose(res.poses[-1], goal)
    mx, my, _ = path_cells(cm, res.poses)
    assert (costs[my, mx] < INSCRIBED_INFLATED_OBSTACLE).all()
    # consecutive poses at most a cell's diagonal apart [m]
    steps = np.hypot(*np.diff(res.poses[:, :2], axis=0).T)
    assert steps.max() <= math.sqrt(2) * RES + 1e-9
    # each yaw points at the next pose
    want = np.arctan2(*np.diff(res.poses[:, :2], axis=0).T[::-1])
    moving = steps > 1e-9
    assert np.allclose(np.angle(np.exp(1j * (res.poses[:-1, 2] - want)))[moving], 0.0, atol=1e-9)


def test_start_cell_is_cleared():
    costs = free_grid()
    costs[10, 10] = LETHAL_OBSTACLE
    cm = make_costmap(costs)
    res = NavfnPlanner().make_plan(cm, (*cell_center(10, 10), 0.0), (*cell_center(40, 30), 0.0))
    assert res.ok, res.reason
    assert cm.costs[10, 10] == LETHAL_OBSTACLE  # the caller's costmap is not modified


def test_walled_off_goal_has_no_path():
    costs = free_grid()
    costs[20:31, 40] = costs[20:31, 50] = LETHAL_OBSTACLE
    costs[20, 40:51] = costs[30, 40:51] = LETHAL_OBSTACLE
    cm = make_costmap(costs)
    goal = cell_center(45, 25)
    res = NavfnPlanner().make_plan(cm, (*cell_center(5, 5), 0.0), (*goal, 0.0))
    assert not res.ok
    assert "no path" in res.reason
    assert len(res.poses) == 0
    assert not np.isfinite(res.potential[25, 45])
    assert np.isfinite(res.potential[40, 10])  # the whole reachable area was searched


def test_goal_in_obstacle_with_and_without_tolerance():
    costs = free_grid()
    costs[25:36, 40:51] = LETHAL_OBSTACLE  # 11 x 11 cells block
    cm = make_costmap(costs)
    start = (*cell_center(5, 5), 0.0)
    goal = (*cell_center(45, 30), 0.7)  # 5 cells = 0.25 m inside from the block's nearest edge
    planner = NavfnPlanner()
    res = planner.make_plan(cm, start, goal, tolerance=0.0)
    assert not res.ok
    assert "in an obstacle (cost 254)" in res.reason

    res = planner.make_plan(cm, start, goal, tolerance=0.5)
    assert res.ok, res.reason
    end = res.poses[-1]
    assert math.hypot(end[0] - goal[0], end[1] - goal[1]) <= 0.5 * math.sqrt(2) + 1e-9
    assert end[2] == goal[2]
    assert cm.cost_at(end[0], end[1]) < INSCRIBED_INFLATED_OBSTACLE
    # the nearest free points are 6 cells away from the goal's cell centre (just outside the block)
    assert math.hypot(end[0] - goal[0], end[1] - goal[1]) == pytest.approx(6 * RES, abs=1e-6)

    # default_tolerance is used when none is given
    assert NavfnPlanner(default_tolerance=0.5).make_plan(cm, start, goal).ok
    # too small a tolerance: still in the obstacle
    res = planner.make_plan(cm, start, goal, tolerance=0.2)
    assert not res.ok and "in an obstacle" in res.reason


def test_unknown_band_and_allow_unknown():
    costs = free_grid()
    costs[:, 30:34] = NO_INFORMATION  # a band of unknown across the map
    cm = make_costmap(costs)
    start, goal = (*cell_center(10, 30), 0.0), (*cell_center(55, 30), 0.0)
    res = NavfnPlanner(allow_unknown=True).make_plan(cm, start, goal)
    assert res.ok, res.reason
    mx, my, _ = path_cells(cm, res.poses)
    assert (costs[my, mx] == NO_INFORMATION).any()
    # crossing 4 unknown cells costs 253 instead of 50 each
    pot = res.potential[30, 55]
    assert pot == pytest.approx(50 * 41 + 253 * 4, rel=0.01)

    res = NavfnPlanner(allow_unknown=False).make_plan(cm, start, goal)
    assert not res.ok
    assert "no path" in res.reason

    # a goal in unknown space is an obstacle without allow_unknown
    res = NavfnPlanner(allow_unknown=False).make_plan(cm, start, (*cell_center(31, 30), 0.0))
    assert not res.ok and "in an obstacle (cost 255)" in res.reason


def test_off_map_start_and_goal():
    cm = make_costmap(free_grid())
    inside = (*cell_center(10, 10), 0.0)
    res = NavfnPlanner().make_plan(cm, inside, (ORIGIN[0] + 10.0, 1.0, 0.0))
    assert not res.ok and "the goal (9.00, 1.00) is off the global costmap" in res.reason
    res = NavfnPlanner().make_plan(cm, (ORIGIN[0] - 0.1, 1.0, 0.0), inside)
    assert not res.ok and "the robot's start (-1.10, 1.00) is off the global costmap" in res.reason
    # just off the map with a tolerance: the closest reachable point within it (as NavfnROS)
    goal = (ORIGIN[0] + 70 * RES + 0.1, ORIGIN[1] + 30.5 * RES, 0.0)
    res = NavfnPlanner().make_plan(cm, inside, goal, tolerance=0.3)
    assert res.ok, res.reason
    assert cm.contains(*res.poses[-1, :2])
    assert res.poses[-1, 0] < ORIGIN[0] + 69 * RES  # the outer ring is never a goal


def test_start_equals_goal():
    cm = make_costmap(free_grid())
    p = (*cell_center(20, 20), 0.4)
    res = NavfnPlanner().make_plan(cm, p, p)
    assert res.ok
    assert np.allclose(res.poses[-1], p)
    assert np.allclose(res.poses[0, :2], p[:2])


def test_planner_window():
    costs = free_grid()
    cm = make_costmap(costs)
    start = (*cell_center(30, 30), 0.0)
    planner = NavfnPlanner(planner_window_x=1.0, planner_window_y=1.0)  # +- 10 cells
    res = planner.make_plan(cm, start, (*cell_center(37, 35), 0.0))
    assert res.ok, res.reason
    assert not np.isfinite(res.potential[5, 5])  # outside the window: not searched
    res = planner.make_plan(cm, start, (*cell_center(55, 30), 0.0))
    assert not res.ok and "outside the planner window" in res.reason
    # a wall with its gap outside the window: no path inside it
    costs[:, 34] = LETHAL_OBSTACLE
    costs[2:4, 34] = FREE_SPACE
    cm = make_costmap(costs)
    assert NavfnPlanner().make_plan(cm, start, (*cell_center(38, 30), 0.0)).ok
    res = planner.make_plan(cm, start, (*cell_center(38, 30), 0.0))
    assert not res.ok and "no path" in res.reason


def test_bad_parameters():
    with pytest.raises(ValueError):
        NavfnPlanner(default_tolerance=-0.1)
    with pytest.raises(ValueError):
        NavfnPlanner(planner_window_x=-1.0)


# --- replanning hysteresis ----------------------------------------------------------------------
def test_path_cost_is_the_weighted_length():
    cm = make_costmap(free_grid())
    line = np.array([[*cell_center(10, 10), 0.0], [*cell_center(50, 40), 0.0]])
    assert path_cost(cm, line) == pytest.approx(50.0 * 50.0, rel=1e-9)  # 50 cells at COST_NEUTRAL
    costs = random_grid(3)
    cm = make_costmap(costs)
    res = NavfnPlanner().make_plan(cm, (*cell_center(3, 3), 0.0), (*cell_center(86, 76), 0.0))
    assert res.ok, res.reason
    reference = weighted_length(cm, ref_trav(costs, robot_cell=(3, 3)), res.poses)
    assert path_cost(cm, res.poses) == pytest.approx(reference, rel=0.02)
    # through an obstacle, off the map, not finite: inf
    costs = free_grid()
    costs[:, 30] = LETHAL_OBSTACLE
    assert path_cost(make_costmap(costs), line) == math.inf
    assert path_cost(cm, np.array([[0.0, 0.0], [50.0, 0.5]])) == math.inf
    assert path_cost(cm, np.array([[np.nan, 1.0], [1.0, 1.0]])) == math.inf
    assert path_cost(cm, np.empty((0, 3))) == math.inf


def loop_grid(block_top=43):
    """A block in the middle of a free grid: two ways from the left to the right (row 28 to row
    28), under it (rows below 18) and over it (rows from ``block_top`` on); with the default the
    way under is a little shorter."""
    costs = free_grid()
    costs[18:block_top, 25:46] = LETHAL_OBSTACLE
    return costs


def way_round(costs, start, goal, over):
    """navfn's plan with the other way walled off."""
    walled = costs.copy()
    if over:
        walled[:28, 35] = LETHAL_OBSTACLE
    else:
        walled[28:, 35] = LETHAL_OBSTACLE
    res = NavfnPlanner().make_plan(make_costmap(walled), start, goal)
    assert res.ok, res.reason
    return res.poses


def test_keep_current_plan_between_two_ways_round_a_loop():
    costs = loop_grid()
    cm = make_costmap(costs)
    start, goal = (*cell_center(10, 28), 0.0), (*cell_center(60, 28), 1.0)
    new = NavfnPlanner().make_plan(cm, start, goal).poses
    assert new[:, 1].min() < cell_center(0, 18)[1]  # navfn goes under the block
    over = way_round(costs, start, goal, over=True)
    assert path_cost(cm, over) > path_cost(cm, new)  # the way over costs more ...
    kept = keep_current_plan(cm, over, new, start[:2], 0.1, 0.5)
    assert kept is not None  # ... but not enough to turn round for
    assert kept[:, 1].max() >= cell_center(0, 43)[1] - 1e-9  # over the block
    assert np.allclose(kept[0, :2], start[:2]) and np.allclose(kept[-1], goal)
    # the robot moved on along the kept way: its rest from the nearest pose
    robot = over[len(over) // 4, :2] + [0.0, 0.02]
    kept = keep_current_plan(cm, over, new, robot, 0.1, 0.5)
    assert kept is not None and np.allclose(kept[0, :2], robot) and len(kept) < len(over)
    # the new plan the same way (the robot a little off the current one): the fresh plan
    same = way_round(costs, start, goal, over=True)
    same[1:-1, 1] += 0.1
    assert 0.09 < plans_apart(same, over) < 0.11
    assert keep_current_plan(cm, over, same, start[:2], 10.0, 100.0) is None
    # a person near the kept way (or what may be one): the fresh plan, round them by their costs
    person = kept[len(kept) // 2, :2] + [0.0, 1.2]
    assert keep_current_plan(cm, over, new, start[:2], 0.1, 0.5, people=[person], people_radius=1.5) is None
    assert keep_current_plan(cm, over, new, start[:2], 0.1, 0.5, people=[person], people_radius=1.0) is not None
    assert keep_current_plan(cm, over, new, start[:2], 0.1, 0.5, people=np.zeros((0, 2))) is not None
    # no hysteresis asked (ROS): the new plan
    assert keep_current_plan(cm, over, new, start[:2], 0.0, 0.0) is None
    # a much longer way is given up
    high = loop_grid(block_top=55)  # over it: 1.2 m more
    cm_high = make_costmap(high)
    over_high = way_round(high, start, goal, over=True)
    new_high = NavfnPlanner().make_plan(cm_high, start, goal).poses
    assert keep_current_plan(cm_high, over_high, new_high, start[:2], 0.1, 0.5) is None
    # the kept way now blocked (a person's inscribed ring, a closed door): never kept
    blocked = costs.copy()
    blocked[41:, 35] = INSCRIBED_INFLATED_OBSTACLE
    assert keep_current_plan(make_costmap(blocked), over, new, start[:2], 10.0, 100.0) is None
    # the robot far from the plan being followed (pushed aside, giving way): the new plan
    assert keep_current_plan(cm, over, new, (start[0], start[1] + 1.0), 10.0, 100.0) is None
    # bad input: no plan, a NaN pose
    assert keep_current_plan(cm, over[:1], new, start[:2], 0.1, 0.5) is None
    broken = over.copy()
    broken[len(over) // 2, 0] = np.nan
    assert keep_current_plan(cm, broken, new, start[:2], 0.1, 0.5) is None
