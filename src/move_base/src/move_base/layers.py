"""costmap_2d's layers in numpy: static map, obstacles from sensors, inflation (ROS-free).

The seed configures its costmaps with the flat, pre-Hydro parameters (``static_map``,
``observation_sources``, ``inflation_radius`` ... in one namespace); the layers here give those
parameters the meaning the layered costmap_2d gives them:

- :class:`StaticLayer` turns a ``nav_msgs/OccupancyGrid``'s data into costs (trinary).
- :class:`ObstacleLayer` keeps its own grid of obstacles marked and cleared by sensor
  observations (points in the costmap's global frame plus the sensor origin).
- :class:`InflationLayer` spreads the lethal cells of the master grid by the robot's size.
- :class:`LayeredCostmap` owns the master :class:`~move_base.costmap_2d.Costmap2D` and combines
  them on each ``update``: static (overwrite) -> obstacles (maximum) -> inflation.

:func:`footprint_cost` is base_local_planner's CostmapModel::footprintCost on any Costmap2D.

Frames and units: every position is in the costmap's global frame [m] (x forward, y left,
REP 103), times are seconds, angles radians.
"""

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from move_base.costmap_2d import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)
from move_base.footprint import circumscribed_radius, inscribed_radius, transform_footprint

log = logging.getLogger(__name__)


# --- line rasterisation ------------------------------------------------------------------------
def bresenham_cells(x0, y0, x1, y1, include_end=True):
    """Cells of the lines from cells (x0, y0) to (x1, y1), all lines at once (integer arrays of
    equal length, or scalars).

    The cells are those of costmap_2d's bresenham2D / base_local_planner's LineIterator: along the
    dominant axis one cell per step, the minor axis advancing when the error term, started at
    half the dominant length (integer division), passes the dominant length. ``include_end``
    (bool or boolean array per line) keeps the end cell (x1, y1).

    Returns (line_index, x, y): int64 arrays, the cells of each line in order from its start.
    """
    x0 = np.atleast_1d(np.asarray(x0, dtype=np.int64))
    y0 = np.atleast_1d(np.asarray(y0, dtype=np.int64))
    x1 = np.atleast_1d(np.asarray(x1, dtype=np.int64))
    y1 = np.atleast_1d(np.asarray(y1, dtype=np.int64))
    dx, dy = x1 - x0, y1 - y0
    adx, ady = np.abs(dx), np.abs(dy)
    major = np.maximum(adx, ady)  # [cells] steps along the dominant axis
    minor = np.minimum(adx, ady)
    count = major + np.broadcast_to(np.asarray(include_end, dtype=np.int64), major.shape)
    line = np.repeat(np.arange(len(major)), count)
    starts = np.cumsum(count) - count
    k = np.arange(len(line), dtype=np.int64) - np.repeat(starts, count)  # step along the line
    den = major[line]
    safe = np.where(den > 0, den, 1)
    m = np.where(den > 0, (den // 2 + k * minor[line]) // safe, 0)  # steps along the minor axis
    x_dominant = (adx >= ady)[line]
    sx, sy = np.sign(dx)[line], np.sign(dy)[line]
    x = x0[line] + sx * np.where(x_dominant, k, m)
    y = y0[line] + sy * np.where(x_dominant, m, k)
    return line, x, y


# --- footprint cost (base_local_planner CostmapModel) -------------------------------------------
# a point robot (fewer than 3 footprint points): the centre cell's cost, or these verdicts
PERSON_BODY = 0.25  # [m] the end of a line of sight to a person's centre left out (map_hides)
_POINT_ROBOT_VERDICT = {NO_INFORMATION: -2.0, LETHAL_OBSTACLE: -1.0, INSCRIBED_INFLATED_OBSTACLE: -1.0}


def footprint_cost(costmap, points_world, position=None):
    """Cost of a footprint placed on ``costmap``: the highest cost of the cells on its outline,
    as base_local_planner's CostmapModel::footprintCost (ROS Noetic) computes it.

    Args:
        costmap: a :class:`Costmap2D`.
        points_world: (N, 2) footprint vertices in the costmap's frame [m], in polygon order.
        position: optional (x, y) [m] of the robot's centre; checked first (off the map: -3),
            and the only cell looked at when the footprint has fewer than 3 points.

    Returns a float: the maximum cost (0..253) of the outline cells, or
        -1.0 a LETHAL_OBSTACLE cell on the outline (or, for a point robot, LETHAL or INSCRIBED),
        -2.0 a NO_INFORMATION cell on the outline,
        -3.0 the centre or a vertex off the map.
    The edges are walked in order (vertex i to i + 1, then last to first), each cell by cell from
    its first vertex, and the first negative verdict met is returned, as ROS does.
    """
    costs = costmap.costs
    points = np.asarray(points_world, dtype=float).reshape(-1, 2)
    if position is not None:
        centre = costmap.world_to_map(float(position[0]), float(position[1]))
        if centre is None:
            return -3.0
        if len(points) < 3:
            cost = int(costs[centre[1], centre[0]])
            return _POINT_ROBOT_VERDICT.get(cost, float(cost))
    if len(points) == 0:
        raise ValueError("footprint_cost needs footprint points (or a position for a point robot)")
    mx, my, inside = costmap.world_to_map(points[:, 0], points[:, 1])
    n = len(points)
    nxt = np.roll(np.arange(n), -1)
    # ROS checks both vertices of an edge before costing it, edge after edge: the first edge with
    # a vertex off the map ends the walk with -3 unless an earlier edge already returned.
    edge_ok = inside & inside[nxt]
    n_good = n if edge_ok.all() else int(np.argmin(edge_ok))
    best = 0.0
    if n_good > 0:
        _, cx, cy = bresenham_cells(mx[:n_good], my[:n_good], mx[nxt][:n_good], my[nxt][:n_good])
        cell_costs = costs[cy, cx]
        bad = (cell_costs == LETHAL_OBSTACLE) | (cell_costs == NO_INFORMATION)
        if bad.any():
            return -1.0 if cell_costs[int(np.argmax(bad))] == LETHAL_OBSTACLE else -2.0
        best = float(cell_costs.max())
    if n_good < n:
        return -3.0
    return best


# --- static layer ------------------------------------------------------------------------------
def polygon_cells(grid, points_world):
    """Cells (mx, my) of ``grid`` covered by the polygon ``points_world`` (N, 2) [m]: those whose
    centre lies inside it, plus its outline (costmap_2d's convexFillCells includes the outline),
    clipped to the grid. Returns two int64 arrays."""
    pts = np.asarray(points_world, dtype=float)
    cx, cy, _ = grid.world_to_map(pts[:, 0], pts[:, 1])
    lo_x, hi_x = max(int(cx.min()), 0), min(int(cx.max()), grid.size_x - 1)
    lo_y, hi_y = max(int(cy.min()), 0), min(int(cy.max()), grid.size_y - 1)
    if lo_x > hi_x or lo_y > hi_y:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    mx, my = np.meshgrid(np.arange(lo_x, hi_x + 1), np.arange(lo_y, hi_y + 1))
    wx, wy = grid.map_to_world(mx.ravel(), my.ravel())
    # crossing-number test of each cell centre against every edge
    x1, y1 = pts[:, 0], pts[:, 1]
    x2, y2 = np.roll(x1, -1), np.roll(y1, -1)
    py = wy[:, None]
    straddles = (y1 <= py) != (y2 <= py)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
    inside = np.count_nonzero(straddles & (wx[:, None] < x_cross), axis=1) % 2 == 1
    ox, oy = mx.ravel()[inside], my.ravel()[inside]
    _, lx, ly = bresenham_cells(cx, cy, np.roll(cx, -1), np.roll(cy, -1))
    keep = (lx >= 0) & (ly >= 0) & (lx < grid.size_x) & (ly < grid.size_y)
    return np.concatenate([ox, lx[keep]]), np.concatenate([oy, ly[keep]])


def same_grid(a, b):
    """Whether two Costmap2D have the same size, resolution and origin."""
    return (a.costs.shape == b.costs.shape and math.isclose(a.resolution, b.resolution)
            and math.isclose(a.origin_x, b.origin_x, abs_tol=1e-9)
            and math.isclose(a.origin_y, b.origin_y, abs_tol=1e-9))


class StaticLayer:
    """Costs from a map (costmap_2d StaticLayer, trinary).

    ``set_map`` takes the OccupancyGrid's int8 data (-1 unknown, 0..100 occupancy): a value
    >= ``lethal_cost_threshold`` is LETHAL_OBSTACLE, -1 is NO_INFORMATION with
    ``track_unknown_space`` and FREE_SPACE without, anything else FREE_SPACE. As in ROS the
    comparison is on the value read as an unsigned byte, so other negative values are lethal.

    A map in another frame than the master grid's (a rolling local costmap in ``odom`` with a
    map in ``map``) is placed by ``pose``: the map frame's (x [m], y [m], yaw [rad]) in the
    master's frame, which the caller keeps up to date (``None``: the frames are the same). While
    ``needs_pose`` is set and no pose is known, the map is not written at all.
    """

    def __init__(self, lethal_cost_threshold=100, track_unknown_space=False):
        self.lethal_cost_threshold = int(lethal_cost_threshold)
        self.track_unknown_space = bool(track_unknown_space)
        self.grid = None  # Costmap2D of the map's geometry, or None before a map came
        self.frame_id = ""
        self.pose = None
        self.needs_pose = False

    @property
    def has_map(self):
        return self.grid is not None

    def set_map(self, data, width, height, resolution, origin_x, origin_y, frame_id="", needs_pose=False):
        """Take a map: ``data`` row-major int8 (height * width values), cell side ``resolution``
        [m], corner of cell (0, 0) at (origin_x, origin_y) [m] in its frame (map's yaw assumed
        0). ``needs_pose``: the map is in another frame than the master grid (see the class)."""
        raw = np.asarray(data).astype(np.int8, copy=False).reshape(int(height), int(width)).view(np.uint8)
        costs = np.full(raw.shape, FREE_SPACE, dtype=np.uint8)
        costs[raw >= self.lethal_cost_threshold] = LETHAL_OBSTACLE
        unknown = raw == 255  # the value -1
        costs[unknown] = NO_INFORMATION if self.track_unknown_space else FREE_SPACE
        grid = Costmap2D(width, height, resolution, origin_x, origin_y, default_value=FREE_SPACE)
        grid.costs = costs
        self.grid = grid
        self.frame_id = frame_id
        self.needs_pose = bool(needs_pose)
        if not self.needs_pose:
            self.pose = None

    def update_costs(self, master):
        """Write the map into the master grid (overwrite, ROS's updateWithTrueOverwrite). Same
        geometry and frame: copied whole. Otherwise (rolling window, or a map placed by
        ``pose``) each master cell that overlaps the map takes the worst of the map cells it
        covers, judged by samples spread over the cell, at least two per map cell side: LETHAL
        if any is, else NO_INFORMATION if any is, else FREE; cells off the map are left as
        they are. The worst, not the cell at the centre, because a coarser or turned master
        grid would otherwise drop thin walls and table edges."""
        placed = self.placed(master)
        if placed is None:
            return
        covered, costs = placed
        if covered is None:
            master.costs[...] = costs
        else:
            master.costs[covered] = costs[covered]

    def same_geometry(self, master):
        """Whether the map has the master grid's size, resolution and origin, in its frame."""
        return self.grid is not None and self.pose is None and same_grid(self.grid, master)

    def placed(self, master):
        """The map on the master grid's cells: (covered, costs), ``covered`` None when the map
        covers the whole grid cell for cell (``costs`` is then the map's own array), else a mask
        of the master cells that overlap the map, with ``costs`` (master's shape) the worst of
        the map cells each covers (see :meth:`update_costs`); None while there is no map (or no
        pose for a map that needs one)."""
        if self.grid is None or (self.needs_pose and self.pose is None):
            return None
        g = self.grid
        if self.same_geometry(master):
            return None, g.costs
        k = math.ceil(master.resolution / g.resolution - 1e-9) + 1  # samples per cell side
        frac = (np.arange(k) + 0.5) / k
        sx = master.origin_x + (np.arange(master.size_x)[:, None] + frac).ravel() * master.resolution
        sy = master.origin_y + (np.arange(master.size_y)[:, None] + frac).ravel() * master.resolution
        wx, wy = np.meshgrid(sx, sy)  # (size_y * k, size_x * k) sample points, master frame
        if self.pose is not None:  # into the map's frame
            px, py, pyaw = self.pose
            c, s = math.cos(pyaw), math.sin(pyaw)
            dx, dy = wx - px, wy - py
            wx, wy = c * dx + s * dy, -s * dx + c * dy
        mx = np.floor((wx - g.origin_x) / g.resolution).astype(np.int64)
        my = np.floor((wy - g.origin_y) / g.resolution).astype(np.int64)
        on_map = (mx >= 0) & (mx < g.size_x) & (my >= 0) & (my < g.size_y)
        rank = np.zeros(mx.shape, dtype=np.uint8)  # 0 off the map, then FREE < NO_INFORMATION < LETHAL
        cost = g.costs[np.where(on_map, my, 0), np.where(on_map, mx, 0)]
        rank[on_map] = _STATIC_RANK[cost[on_map]]
        worst = rank.reshape(master.size_y, k, master.size_x, k).max(axis=(1, 3))
        return worst > 0, _RANKED_COST[worst]


class KeepoutLayer(StaticLayer):
    """Places the robot must not enter, from a map of its own (Nav2's keepout filter; a user draws
    it over a copy of the robot's map: under tables, rugs, steps).

    Every cell of the keep-out map at or above ``lethal_cost_threshold`` makes the master cells it
    covers LETHAL_OBSTACLE; every other value (free, unknown, in between) changes nothing. It is
    written before the inflation, so the robot's whole body keeps out, not only its centre
    (Nav2's filter acts after the inflation). A map of another size, resolution or origin than
    the master grid is placed by its own origin and resolution (each master cell lethal when any
    keep-out cell it covers is); the node warns about it."""

    def __init__(self, lethal_cost_threshold=100):
        super().__init__(lethal_cost_threshold, track_unknown_space=False)

    def update_costs(self, master):
        placed = self.placed(master)
        if placed is None:
            return
        covered, costs = placed
        lethal = costs == LETHAL_OBSTACLE
        if covered is not None:
            lethal &= covered
        master.costs[lethal] = LETHAL_OBSTACLE


_STATIC_RANK = np.ones(256, dtype=np.uint8)  # a static cost's rank (static costs are trinary)
_STATIC_RANK[NO_INFORMATION] = 2
_STATIC_RANK[LETHAL_OBSTACLE] = 3
_RANKED_COST = np.array([FREE_SPACE, FREE_SPACE, NO_INFORMATION, LETHAL_OBSTACLE], dtype=np.uint8)


# --- obstacle layer ----------------------------------------------------------------------------
@dataclass
class ObservationSource:
    """One sensor's parameters (costmap_2d observation source; ROS defaults).

    name: the source's name (for messages).
    obstacle_range [m]: points farther than this from the sensor (3-D) do not mark.
    raytrace_range [m]: rays clear at most this far from the sensor (in the plane).
    min_obstacle_height, max_obstacle_height [m]: points outside these heights are dropped
        (neither mark nor clear), as ROS's ObservationBuffer does.
    marking, clearing: whether the source marks obstacles / clears free space.
    observation_persistence [s]: how long an observation is kept (0: only the latest).
    expected_update_rate [s]: longest allowed time between observations (0: not checked).
    """

    name: str
    obstacle_range: float = 2.5
    raytrace_range: float = 3.0
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 2.0
    marking: bool = True
    clearing: bool = False
    observation_persistence: float = 0.0
    expected_update_rate: float = 0.0


@dataclass
class Observation:
    """One sensor reading in the costmap's global frame.

    origin: (3,) sensor position [m].
    points: (N, 3) real returns [m] (already filtered by height when stored in a buffer).
    free_ends: (M, 3) points along rays that saw nothing: readings at/over the sensor's range;
        each clears a ray of length raytrace_range in its direction and marks nothing.
    stamp: time of the reading [s].
    clear_points: (K, 3) every return whatever its height (the voxel layer clears along the
        rays to them), or None: ``points``.
    """

    origin: np.ndarray
    points: np.ndarray
    free_ends: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    stamp: float = 0.0
    clear_points: np.ndarray | None = None


class ObservationBuffer:
    """The recent observations of one source (costmap_2d ObservationBuffer)."""

    def __init__(self, source, now=0.0):
        self.source = source
        self.observations = []
        self.last_updated = float(now)  # [s] ROS starts the clock at construction

    def add(self, origin, points, free_ends=None, stamp=0.0, now=None):
        """Store a reading (see :class:`Observation`); points outside the source's height limits
        are dropped. ``now`` [s] (default ``stamp``) is the time it arrived."""
        src = self.source
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        points = points[np.isfinite(points).all(axis=1)]  # NaN / inf: no reading
        keep = (points[:, 2] >= src.min_obstacle_height) & (points[:, 2] <= src.max_obstacle_height)
        free = np.zeros((0, 3)) if free_ends is None else np.asarray(free_ends, dtype=float).reshape(-1, 3)
        self.observations.append(Observation(np.asarray(origin, dtype=float).reshape(3), points[keep], free, stamp,
                                             clear_points=points))
        self.last_updated = float(stamp if now is None else now)
        self.purge()

    def purge(self):
        """Drop what the persistence does not keep (ROS purgeStaleObservations): with 0 only the
        latest; otherwise those older than ``observation_persistence`` before the last update."""
        if not self.observations:
            return
        keep_time = self.source.observation_persistence
        if keep_time == 0.0:
            self.observations = self.observations[-1:]
        else:
            self.observations = [o for o in self.observations if self.last_updated - o.stamp <= keep_time]

    def is_current(self, now):
        """False when ``expected_update_rate`` > 0 and no observation came for longer than it."""
        rate = self.source.expected_update_rate
        return rate == 0.0 or (now - self.last_updated) <= rate

    def reset_last_updated(self, now):
        self.last_updated = float(now)


class ObstacleLayer:
    """Obstacles seen by the sensors, on the layer's own grid (costmap_2d ObstacleLayer).

    On each update every clearing observation is ray-traced first (cells on the ray from the
    sensor to each return, cut at raytrace_range, become FREE_SPACE; the end cell of a return
    that was not cut is left as it is), then every marking observation marks its points closer
    than obstacle_range (3-D distance to the sensor) LETHAL_OBSTACLE. The grid starts
    NO_INFORMATION with ``track_unknown_space`` and FREE_SPACE without; a NO_INFORMATION cell of
    this layer does not change the master grid (see :meth:`update_costs`).
    """

    def __init__(self, sources=(), track_unknown_space=False, now=0.0):
        self.track_unknown_space = bool(track_unknown_space)
        self.default_value = NO_INFORMATION if self.track_unknown_space else FREE_SPACE
        self.buffers = {s.name: ObservationBuffer(s, now) for s in sources}
        self.grid = None

    def match_size(self, master):
        """Take the master's geometry, every cell back to the default."""
        self.grid = Costmap2D(
            master.size_x, master.size_y, master.resolution, master.origin_x, master.origin_y, self.default_value
        )

    def update_origin(self, origin_x, origin_y):
        self.grid.update_origin(origin_x, origin_y)

    def add_observation(self, source_name, origin, points, free_ends=None, stamp=0.0, now=None):
        """Buffer a reading of source ``source_name`` (see :meth:`ObservationBuffer.add`)."""
        self.buffers[source_name].add(origin, points, free_ends, stamp, now)

    def is_current(self, now):
        return all(b.is_current(now) for b in self.buffers.values())

    def stale_sources(self, now):
        """Names of the sources whose observations are older than their expected_update_rate."""
        return [name for name, b in self.buffers.items() if not b.is_current(now)]

    def reset(self, now=None):
        """Grid back to the default; the buffers are kept, their clocks restarted (ROS reset)."""
        if self.grid is not None:
            self.grid.costs[...] = self.default_value
        if now is not None:
            for b in self.buffers.values():
                b.reset_last_updated(now)

    def update(self, clear_discs=None):
        """Clear, then mark, with the buffered observations (ROS updateBounds). ``clear_discs``
        (N, 3) x, y, radius [m]: cells to free after the ray tracing and before the marking (where
        tracked people walked: what a sensor still sees there is marked again)."""
        if self.grid is None:
            return
        for b in self.buffers.values():
            b.purge()
        clearing = [(b.source, o) for b in self.buffers.values() if b.source.clearing for o in b.observations]
        marking = [(b.source, o) for b in self.buffers.values() if b.source.marking for o in b.observations]
        if clearing:
            self._raytrace(clearing)
        self.clear_discs(clear_discs)
        if marking:
            self._mark(marking)

    def clear_discs(self, discs):
        """Free the cells within each disc (x, y, radius) [m] (see :meth:`update`)."""
        if discs is None or len(discs) == 0 or self.grid is None:
            return
        g = self.grid
        for x, y, r in np.asarray(discs, dtype=float).reshape(-1, 3):
            rows, cols = _window(g, x, y, 2.0 * r)
            ys, xs = np.mgrid[rows, cols]
            if xs.size == 0:
                continue
            wx, wy = g.map_to_world(xs, ys)
            inside = (wx - x) ** 2 + (wy - y) ** 2 <= r * r
            self.clear_cells(xs[inside], ys[inside])

    def _raytrace(self, clearing):
        g = self.grid
        starts, ends, include_end = [], [], []
        for src, obs in clearing:
            ox, oy = obs.origin[0], obs.origin[1]
            if g.world_to_map(ox, oy) is None:
                log.warning(
                    "the origin of sensor %s at (%.2f, %.2f) is off the costmap: it cannot clear", src.name, ox, oy
                )
                continue
            rr = src.raytrace_range
            # real returns: cut at raytrace_range; the end cell is cleared only when cut
            d = obs.points[:, :2] - obs.origin[:2]
            length = np.hypot(d[:, 0], d[:, 1])
            cut = length > rr
            scale = np.where(cut, rr / np.where(length > 0, length, 1.0), 1.0)
            ends.append(obs.origin[:2] + d * scale[:, None])
            include_end.append(cut)
            # rays without a return: raytrace_range long, end cell cleared
            f = obs.free_ends[:, :2] - obs.origin[:2]
            flen = np.hypot(f[:, 0], f[:, 1])
            fok = flen > 0
            ends.append(obs.origin[:2] + f[fok] * (rr / flen[fok])[:, None])
            include_end.append(np.ones(int(fok.sum()), dtype=bool))
            starts.append(np.repeat(obs.origin[None, :2], len(d) + int(fok.sum()), axis=0))
        if not starts:
            return
        start = np.concatenate(starts)
        end = np.concatenate(ends)
        inc = np.concatenate(include_end)
        if len(start) == 0:
            return
        res = g.resolution
        x0 = np.floor((start[:, 0] - g.origin_x) / res).astype(np.int64)
        y0 = np.floor((start[:, 1] - g.origin_y) / res).astype(np.int64)
        x1 = np.floor((end[:, 0] - g.origin_x) / res).astype(np.int64)
        y1 = np.floor((end[:, 1] - g.origin_y) / res).astype(np.int64)
        _, cx, cy = bresenham_cells(x0, y0, x1, y1, inc)
        on = (cx >= 0) & (cy >= 0) & (cx < g.size_x) & (cy < g.size_y)
        g.costs[cy[on], cx[on]] = FREE_SPACE

    def _mark(self, marking):
        g = self.grid
        for src, obs in marking:
            p = obs.points
            if len(p) == 0:
                continue
            sq = np.sum((p - obs.origin) ** 2, axis=1)
            near = sq < src.obstacle_range * src.obstacle_range
            mx, my, inside = g.world_to_map(p[near, 0], p[near, 1])
            g.costs[my[inside], mx[inside]] = LETHAL_OBSTACLE

    def band(self, z_band):
        """Cells marked at heights within ``z_band`` (a 2-D layer: every lethal cell)."""
        return self.grid.costs == LETHAL_OBSTACLE

    def clear_cells(self, mx, my):
        """Cells (mx, my) (index arrays) become FREE_SPACE: the robot's footprint."""
        self.grid.costs[my, mx] = FREE_SPACE

    def update_costs(self, master):
        """Combine into the master grid by maximum, as ROS's updateWithMax: cells of this layer at
        NO_INFORMATION are skipped; a master cell at NO_INFORMATION takes this layer's cost."""
        if self.grid is None:
            return
        mine = self.grid.costs
        old = master.costs
        write = (mine != NO_INFORMATION) & ((old == NO_INFORMATION) | (old < mine))
        old[write] = mine[write]

    def clear_outside(self, x, y, size):
        """ROS ClearCostmapRecovery on this layer: every cell outside the square of side ``size``
        [m] centred on (x, y) [m] becomes NO_INFORMATION (no say in the master grid). The kept
        window is the cells strictly between the corner cells (ROS's ``x > start_x && x < end_x``),
        corner cells by truncation (worldToMapNoBounds). Returns the mask of the cells kept."""
        g = self.grid
        if g is None:
            return None
        sx, sy = g.world_to_map_no_bounds(x - size / 2.0, y - size / 2.0)
        ex, ey = g.world_to_map_no_bounds(x - size / 2.0 + size, y - size / 2.0 + size)
        ix = np.arange(g.size_x)
        iy = np.arange(g.size_y)
        keep = ((iy > sy) & (iy < ey))[:, None] & ((ix > sx) & (ix < ex))[None, :]
        g.costs[~keep] = NO_INFORMATION
        return keep

    def clear_unknown_around(self, x, y, size):
        """Cells at NO_INFORMATION in the square of side ``size`` [m] centred on (x, y) [m]
        become FREE_SPACE in this layer."""
        g = self.grid
        if g is None:
            return
        window = _window(g, x, y, size)
        sub = g.costs[window]
        sub[sub == NO_INFORMATION] = FREE_SPACE


def _window(grid, x, y, size):
    """Slices (rows, cols) of the cells whose centres lie in the square of side ``size`` [m]
    centred on (x, y) [m], clipped to the grid."""
    res = grid.resolution
    lo_x = math.ceil((x - size / 2.0 - grid.origin_x) / res - 0.5)
    hi_x = math.floor((x + size / 2.0 - grid.origin_x) / res - 0.5)
    lo_y = math.ceil((y - size / 2.0 - grid.origin_y) / res - 0.5)
    hi_y = math.floor((y + size / 2.0 - grid.origin_y) / res - 0.5)
    lo_x, lo_y = max(lo_x, 0), max(lo_y, 0)
    hi_x, hi_y = min(hi_x, grid.size_x - 1), min(hi_y, grid.size_y - 1)
    return slice(lo_y, max(hi_y + 1, lo_y)), slice(lo_x, max(hi_x + 1, lo_x))


def _combine_max(master, costs):
    """ObstacleLayer.update_costs with the costs array ``costs`` (the layer's grid, edited)."""
    old = master.costs
    write = (costs != NO_INFORMATION) & ((old == NO_INFORMATION) | (old < costs))
    old[write] = costs[write]


# --- inflation layer ---------------------------------------------------------------------------
def inflation_cost(distance, inscribed_radius, cost_scaling_factor):
    """costmap_2d's inflation cost at ``distance`` [m] from a lethal cell (array or scalar):
    254 at 0, 253 up to ``inscribed_radius`` [m], beyond it
    ``(unsigned char)(252 * exp(-cost_scaling_factor * (distance - inscribed_radius)))``."""
    d = np.asarray(distance, dtype=float)
    decay = (INSCRIBED_INFLATED_OBSTACLE - 1) * np.exp(-cost_scaling_factor * (d - inscribed_radius))
    cost = np.where(
        d == 0.0,
        LETHAL_OBSTACLE,
        np.where(d <= inscribed_radius, INSCRIBED_INFLATED_OBSTACLE, np.floor(np.clip(decay, 0, 252))),
    ).astype(np.uint8)
    return int(cost) if cost.ndim == 0 else cost


class InflationLayer:
    """Lethal cells of the master grid spread by the robot's size (costmap_2d InflationLayer).

    A cell at distance d from the nearest lethal cell (between cell centres,
    ``scipy.ndimage.distance_transform_edt``; d = cells * resolution as ROS computes it) gets
    :func:`inflation_cost` (d) when d is within ROS's cell inflation radius,
    ``ceil(inflation_radius / resolution)`` cells (costmap_2d's cellDistance: ROS inflates up to
    that whole number of cells: 0.55 m at 0.1 m resolution reaches 6 cells, 0.6 m; the seed's
    0.40 m is a whole number of cells at both its resolutions, 0.05 and 0.1 m).

    Combination, as ROS's InflationLayer::enqueue (costmap_2d plugins/inflation_layer.cpp):
    ``if (old_cost == NO_INFORMATION && cost >= INSCRIBED_INFLATED_OBSTACLE) grid = cost;
    else grid = max(old_cost, cost)``, i.e. a known cell keeps the larger of its cost and the
    inflated one, and an unknown cell (255 is the largest value) stays unknown unless it is
    within the inscribed radius of an obstacle, where it takes 253 (or 254).
    """

    def __init__(self, inscribed_radius, inflation_radius=0.55, cost_scaling_factor=10.0):
        self.inscribed_radius = float(inscribed_radius)
        self.inflation_radius = float(inflation_radius)
        self.cost_scaling_factor = float(cost_scaling_factor)

    def update_costs(self, master):
        costs = master.costs
        lethal = costs == LETHAL_OBSTACLE
        if not lethal.any():
            return
        res = master.resolution
        cell_radius = max(0, math.ceil(self.inflation_radius / res))
        if cell_radius == 0:
            return
        d_cells = ndimage.distance_transform_edt(~lethal)
        near = (d_cells <= cell_radius) & ~lethal
        if not near.any():
            return
        cost = inflation_cost(d_cells[near] * res, self.inscribed_radius, self.cost_scaling_factor)
        cost = np.atleast_1d(cost)
        old = costs[near]
        new = np.where(
            old == NO_INFORMATION,
            np.where(cost >= INSCRIBED_INFLATED_OBSTACLE, cost, NO_INFORMATION),
            np.maximum(old, cost),
        )
        costs[near] = new


# --- the layered costmap -----------------------------------------------------------------------
class LayeredCostmap:
    """The master grid and its layers (costmap_2d LayeredCostmap with static, obstacle and
    inflation layers), ROS-free.

    Args:
        size_x, size_y: grid size [cells]; resolution [m/cell]; origin_x, origin_y [m] corner
            of cell (0, 0) (a static map, when it comes, replaces the geometry unless
            ``rolling_window``).
        footprint: (N, 2) padded footprint [m] in the base frame.
        rolling_window: the grid follows the robot (re-centred on every update).
        track_unknown_space: unknown stays NO_INFORMATION (default cost of the master and
            obstacle grids, and the static map's -1).
        static_map: whether a static layer is used.
        sources: :class:`ObservationSource` list of the obstacle layer.
        inflation_radius [m], cost_scaling_factor [1/m], lethal_cost_threshold (map value).
        now [s]: time the observation buffers' clocks start at.
    """

    def __init__(
        self,
        size_x,
        size_y,
        resolution,
        origin_x=0.0,
        origin_y=0.0,
        footprint=None,
        rolling_window=False,
        track_unknown_space=False,
        static_map=True,
        sources=(),
        inflation_radius=0.55,
        cost_scaling_factor=10.0,
        lethal_cost_threshold=100,
        now=0.0,
        voxel=None,
        keepout=False,
        proxemic=None,
    ):
        self.rolling_window = bool(rolling_window)
        self.track_unknown_space = bool(track_unknown_space)
        default = NO_INFORMATION if self.track_unknown_space else FREE_SPACE
        self.costmap = Costmap2D(size_x, size_y, resolution, origin_x, origin_y, default_value=default)
        if footprint is None:
            from move_base.footprint import parse_footprint

            footprint = parse_footprint(None)
        self.footprint = np.asarray(footprint, dtype=float)
        self.inscribed_radius = inscribed_radius(self.footprint)
        self.circumscribed_radius = circumscribed_radius(self.footprint)
        self.static = StaticLayer(lethal_cost_threshold, track_unknown_space) if static_map else None
        if voxel is not None:
            from move_base.voxel_layer import VoxelLayer

            self.obstacles = VoxelLayer(sources, track_unknown_space, now, **voxel)
        else:
            self.obstacles = ObstacleLayer(sources, track_unknown_space, now)
        self.obstacles.match_size(self.costmap)
        self.keepout = KeepoutLayer(lethal_cost_threshold) if keepout else None
        if proxemic is not None:
            from move_base.people_layer import ProxemicLayer

            self.people = ProxemicLayer(**proxemic)
        else:
            self.people = None
        self._now = None  # [s] time of the last update (the people's costs are for it)
        self._robot = None  # (x, y) [m] of the robot at the last update
        self.inflation = InflationLayer(self.inscribed_radius, inflation_radius, cost_scaling_factor)
        self._under_robot = None  # (mx, my) master cells under the footprint at the last update

    @property
    def layers(self):
        return [layer for layer in (self.static, self.obstacles, self.keepout, self.people, self.inflation)
                if layer is not None]

    def has_map(self):
        """True when the static layer got its map, or there is no static layer."""
        return self.static is None or self.static.has_map

    def set_static_map(self, data, width, height, resolution, origin_x, origin_y, frame_id="", needs_pose=False):
        """Give the static layer its map. Without a rolling window the master grid (and the
        obstacle layer, reset) take the map's size, resolution and origin, as ROS's StaticLayer
        does with resizeMap. ``needs_pose``: the map is in another frame, placed by
        :meth:`set_static_pose` (rolling window only)."""
        if self.static is None:
            raise RuntimeError("this costmap has no static layer (static_map is false)")
        if needs_pose and not self.rolling_window:
            raise ValueError("only a rolling window places a static map of another frame")
        self.static.set_map(data, width, height, resolution, origin_x, origin_y, frame_id, needs_pose)
        if not self.rolling_window:
            c = self.costmap
            if (
                c.size_x != int(width)
                or c.size_y != int(height)
                or c.resolution != float(resolution)
                or c.origin_x != float(origin_x)
                or c.origin_y != float(origin_y)
            ):
                c.resize(width, height, resolution, origin_x, origin_y)
                self.obstacles.match_size(c)

    def set_static_pose(self, pose):
        """Where the static map's frame is in the grid's frame now: (x [m], y [m], yaw [rad])."""
        if self.static is not None:
            self.static.pose = None if pose is None else tuple(float(v) for v in pose)

    def set_keepout_map(self, data, width, height, resolution, origin_x, origin_y, frame_id="", needs_pose=False):
        """Give the keep-out layer its map (arguments as :meth:`set_static_map`); the grid keeps
        its geometry. Returns whether the keep-out map has the static map's geometry (False: it is
        placed by its own origin and resolution)."""
        if self.keepout is None:
            raise RuntimeError("this costmap has no keep-out layer")
        self.keepout.set_map(data, width, height, resolution, origin_x, origin_y, frame_id, needs_pose)
        return self.keepout_matches_map()

    def keepout_matches_map(self):
        """Whether the keep-out map has the static map's size, resolution and origin (the master
        grid's without a static map); None before either map came."""
        if self.keepout is None or self.keepout.grid is None:
            return None
        if self.static is not None:
            if self.static.grid is None:
                return None
            return same_grid(self.keepout.grid, self.static.grid)
        return same_grid(self.keepout.grid, self.costmap)

    def set_keepout_pose(self, pose):
        """Where the keep-out map's frame is in the grid's frame now: (x [m], y [m], yaw [rad])."""
        if self.keepout is not None:
            self.keepout.pose = None if pose is None else tuple(float(v) for v in pose)

    def update(self, robot_x, robot_y, robot_yaw=None, now=None):
        """One costmap cycle for a robot at (robot_x, robot_y) [m] at time ``now`` [s] (the people's
        costs are for it; None: the last message's people as they were): move a rolling window, clear
        and mark the obstacle layer, clear the robot's footprint in it (heading ``robot_yaw``
        [rad]; costmap_2d clears the cells under the robot: whatever is there is the robot
        itself or a stale mark), then rebuild the master grid: default, static (overwrite),
        obstacles (maximum), inflation.

        A rolling window also frees the cells under the footprint in what the static and keep-out
        layers wrote: a map placed through the localization's pose is off by its error, and a map cell
        under the robot is that error, not an obstacle. Left in, it would hold every trajectory
        (the footprint's outline on a lethal cell) with no recovery to clear it; the cells just
        outside the footprint stay, so the robot can move off the map's obstacle, not into it."""
        c = self.costmap
        self._now = now
        self._robot = (float(robot_x), float(robot_y))
        if self.rolling_window:
            w, h = c.size_m
            c.update_origin(robot_x - w / 2.0, robot_y - h / 2.0)
            self.obstacles.update_origin(robot_x - w / 2.0, robot_y - h / 2.0)
        # where tracked people walked lately, the sensors' marks are theirs, not furniture's: freed
        # before the newest readings mark what is there now (a walker who left the Kinect's view
        # would otherwise leave a trail of voxels behind)
        self.obstacles.update(None if self.people is None else self.people.trail(now))
        if self.people is not None and self.people.follow_speed > 0.0:
            # a person walking away is followed, not planned round (people_layer): what the sensors
            # see of them now is freed too
            followed = self.people.followed(now, self._robot)
            self.obstacles.clear_discs(np.column_stack([followed[:, :2], np.full(len(followed),
                                                                                   self.people.trail_radius)]))
        if self.people is not None and self.people.unseen_keep_time > 0.0 and now is not None:
            self.people.observe(now, float(robot_x), float(robot_y), robot_yaw, self.map_hides)
        self._under_robot = None
        if robot_yaw is not None:
            self._under_robot = polygon_cells(c, transform_footprint(self.footprint, robot_x, robot_y, robot_yaw))
            if self.obstacles.grid is not None:  # the same geometry as the master grid
                self.obstacles.clear_cells(*self._under_robot)
        self._recombine()

    def forget_unseen_people(self):
        """Forget the people the proxemic layer holds out of the sensors' view (its
        unseen_keep_time) and rebuild the master grid; returns how many there were (0: nothing
        changed)."""
        if self.people is None:
            return 0
        held = self.people.release_unseen()
        if held:
            self._recombine()
        return held

    def map_hides(self, x0, y0, x1, y1, near=PERSON_BODY):
        """Whether the static map has a lethal cell on the line from (x0, y0) to (x1, y1) [m],
        the last ``near`` [m] left out (the person standing there, beside a wall perhaps): the
        sensors at (x0, y0) cannot see a person at (x1, y1) through a wall. False without a map
        in the grid's frame, or for a line leaving the map."""
        if self.static is None or self.static.grid is None or self.static.pose is not None:
            return False
        g = self.static.grid
        length = math.hypot(x1 - x0, y1 - y0)
        if length <= near:
            return False
        end = 1.0 - near / length
        start, stop = g.world_to_map(x0, y0), g.world_to_map(x0 + (x1 - x0) * end, y0 + (y1 - y0) * end)
        if start is None or stop is None:
            return False
        _, mx, my = bresenham_cells(*start, *stop)
        return bool(np.any(g.costs[my, mx] == LETHAL_OBSTACLE))

    def reset_layers(self, now=None):
        """Every layer back to its start (ROS resetLayers): obstacles forgotten, the master grid
        back to the static map (or the default) with its inflation."""
        self.obstacles.reset(now)
        self._recombine()

    def clear_outside(self, x, y, size):
        """ClearCostmapRecovery: the obstacle layer forgets everything outside the square of side
        ``size`` [m] centred on (x, y) [m]; the master grid is rebuilt from the layers."""
        self.obstacles.clear_outside(x, y, size)
        self._recombine()

    def clear_unknown_around(self, x, y, size):
        """Cells at NO_INFORMATION in the square of side ``size`` [m] centred on (x, y) [m] become
        FREE_SPACE, in the obstacle layer (so it lasts: a free obstacle-layer cell overrides an
        unknown static cell) and in the master grid, which is then rebuilt from the layers."""
        self.obstacles.clear_unknown_around(x, y, size)
        self._recombine()

    def _recombine(self):
        self._combine(self.costmap, people=True)

    def _combine(self, c, people=True, obstacles=None):
        """Rebuild grid ``c`` (the master's geometry) from the layers: default, static
        (overwrite), obstacles (maximum; ``obstacles`` replaces the obstacle layer's grid),
        keep-out (lethal), in a rolling window the cells under the robot freed (see
        :meth:`update`), people (with ``people``), inflation."""
        c.costs[...] = c.default_value
        if self.static is not None:
            self.static.update_costs(c)
        if obstacles is None:
            self.obstacles.update_costs(c)
        else:
            _combine_max(c, obstacles)
        if self.keepout is not None:
            self.keepout.update_costs(c)
        if self.rolling_window and self._under_robot is not None:
            mx, my = self._under_robot
            c.costs[my, mx] = FREE_SPACE
        if people and self.people is not None:
            # no lethal person cell within the inscribed radius and two cells of the robot: a person
            # standing close must not wall in the robot's own cell (no plan could leave it)
            robot = None if self._robot is None else (*self._robot, self.inscribed_radius + 2.0 * c.resolution)
            self.people.update_costs(c, self._now, robot)
        self.inflation.update_costs(c)

    def map_only(self):
        """A copy of the master grid built from the maps alone (static and keep-out layers and their
        inflation): no sensor marks, no people. Where a plan exists on it but not on the master
        grid, something the map does not have stands in the way: people, or things that move."""
        c = self.costmap.copy()
        empty = np.full(c.costs.shape, NO_INFORMATION, dtype=np.uint8)
        self._combine(c, people=False, obstacles=empty)
        return c

    def unmapped_marks(self, x, y, radius, z_band=(0.05, 0.35), tolerance=0.15):
        """(N, 2) [m] the returns of the sensors' newest readings within ``radius`` [m] of (x, y)
        and between the heights ``z_band`` [m] (a person's legs, where the laser sees them) that lie
        farther than ``tolerance`` [m] (the localization's error) from every lethal cell of the
        static and keep-out layers: what may be a person the tracker does not know. Only what the
        sensors see now counts (not older marks of the obstacle layer: a person who walked on is
        no longer there). One point per cell of the grid."""
        g = self.obstacles.grid
        if g is None:
            return np.zeros((0, 2))
        pts = [b.observations[-1].points for b in self.obstacles.buffers.values()
               if b.source.marking and b.observations]
        if not pts:
            return np.zeros((0, 2))
        p = np.concatenate(pts)
        keep = ((p[:, 2] >= z_band[0]) & (p[:, 2] <= z_band[1])
                & ((p[:, 0] - x) ** 2 + (p[:, 1] - y) ** 2 <= radius * radius))
        mx, my, inside = g.world_to_map(p[keep, 0], p[keep, 1])
        mx, my = mx[inside], my[inside]
        unmapped = ~self._mapped(tolerance)[my, mx]
        cells = np.unique(my[unmapped] * g.size_x + mx[unmapped])
        wx, wy = g.map_to_world(cells % g.size_x, cells // g.size_x)
        return np.column_stack([np.atleast_1d(wx), np.atleast_1d(wy)]).reshape(-1, 2)

    def _mapped(self, tolerance):
        """Cells within ``tolerance`` [m] of a lethal cell of the static and keep-out layers, on the
        master's geometry (the maps placed as at the last update)."""
        c = self.costmap
        key = (id(self.static.grid) if self.static is not None else None,
               id(self.keepout.grid) if self.keepout is not None else None,
               self.static.pose if self.static is not None else None,
               self.keepout.pose if self.keepout is not None else None, c.origin_x, c.origin_y, tolerance)
        if getattr(self, "_mapped_key", None) != key:
            scratch = Costmap2D(c.size_x, c.size_y, c.resolution, c.origin_x, c.origin_y)
            lethal = np.zeros(c.costs.shape, dtype=bool)
            for layer in (self.static, self.keepout):
                if layer is not None:
                    scratch.costs[...] = FREE_SPACE
                    layer.update_costs(scratch)
                    lethal |= scratch.costs == LETHAL_OBSTACLE
            cells = max(0, math.ceil(tolerance / c.resolution))
            self._mapped_mask = ndimage.binary_dilation(lethal, iterations=cells) if cells and lethal.any() else lethal
            self._mapped_key = key
        return self._mapped_mask

    def footprint_cost(self, x, y, yaw):
        """:func:`footprint_cost` of the robot at (x, y) [m] heading ``yaw`` [rad] on the master grid."""
        return footprint_cost(self.costmap, transform_footprint(self.footprint, x, y, yaw), (x, y))
