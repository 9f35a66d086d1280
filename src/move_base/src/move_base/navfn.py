"""navfn's global planner: an interpolated navigation function on a costmap (ROS-free).

Follows ROS 1 ``navfn`` (``NavFn`` in navfn.cpp, ``NavfnROS::makePlan`` in navfn_ros.cpp):

1. Cost translation (``NavFn::setCostmap`` with ``isROS = true``; constants from navfn.h:
   ``COST_NEUTRAL = 50``, ``COST_FACTOR = 3``, ``COST_OBS_ROS = 253``, ``COST_OBS = 254``,
   ``COST_UNKNOWN_ROS = 255``). A costmap cell of cost ``c`` becomes the traversal cost

   - ``c in 0..252``: ``min(COST_NEUTRAL + COST_FACTOR * c, COST_OBS - 1)``, i.e. 50..253
     (saturating at 253 from ``c = 68`` on);
   - ``c = 253`` (inscribed) or ``254`` (lethal): ``COST_OBS`` (254), an obstacle;
   - ``c = 255`` (unknown): ``COST_OBS - 1`` (253, passable but expensive) when
     ``allow_unknown``, else ``COST_OBS``.

   As ``NavFn::setupNavFn`` does, the outer ring of cells is then set to ``COST_OBS``, so a
   path never runs along the map's edge; and as ``NavfnROS::clearRobotCell`` does, the
   robot's own cell is free (``COST_NEUTRAL``) whatever the costmap says. (NavfnROS writes
   FREE_SPACE into the costmap itself; here only the translated copy is changed.)

2. Potential: the wavefront of ``NavFn::updateCell``. A cell's potential is computed from
   its two lowest 4-neighbours ``ta <= tc`` and its traversal cost ``hf``:
   ``ta + hf`` if ``tc - ta >= hf``, else ``ta + hf * (-0.2301 d^2 + 0.5307 d + 0.7040)``
   with ``d = (tc - ta) / hf`` (a quadratic fit of the planar-wave update). Units: traversal
   cost x cells. NavfnROS puts potential 0 at the *robot's* cell (it calls ``setGoal`` with
   the robot's cell and ``setStart`` with the goal's) and propagates until the goal cell has
   a potential, or over everything reachable when it never gets one. Cells are expanded in
   order of potential with a binary heap (navfn uses threshold-ordered priority buffers,
   which only approximate that order).

3. Goal selection (``NavfnROS::makePlan``): the points on a grid of ``resolution`` steps in
   the square ``goal +- tolerance`` are tested, and the one with a finite potential closest
   to the goal becomes the plan's end. With ``tolerance = 0`` only the goal itself is tested.

4. Path (``NavFn::calcPath``): descent from the chosen end cell to the robot's cell,
   ``PATH_STEP = 0.5`` cell per step along the bilinearly interpolated, normalised gradient
   of the potential; where a cell of the 3 x 3 block around the current point has no
   potential (obstacle, unreached), or the path oscillates, or the gradient vanishes, it
   steps to the lowest of the 8 neighbouring cells instead. It ends when the current cell's
   potential is below ``COST_NEUTRAL`` (only the robot's cell is). The path is reversed to
   run robot -> goal, and the goal pose itself is appended, as NavfnROS does.

Differences from NavfnROS, on purpose:
- Path points are cell *centres* plus the interpolation offset (NavfnROS's ``mapToWorld``
  maps cell index ``i`` to the cell's corner, shifting its paths by half a cell).
- The first pose is the robot's exact position (not its cell) and the goal's cell is not
  repeated before the goal pose; each pose's yaw points at the next pose (NavfnROS leaves
  the identity orientation on all poses but the goal).
- A goal in an obstacle gets its own failure reason; NavfnROS just fails to find a plan.
- ``planner_window_x/y`` (read but unused by NavfnROS) crop the search to a window around
  the robot, see :class:`NavfnPlanner`.
"""

import dataclasses
import logging
import math

import numba
import numpy as np

from florence_common.params import Param, ParamTable
from move_base.costmap_2d import INSCRIBED_INFLATED_OBSTACLE, NO_INFORMATION

log = logging.getLogger(__name__)

# navfn.h constants (traversal-cost units).
COST_NEUTRAL = 50  # cost of a free cell
COST_FACTOR = 3  # costmap cost -> traversal cost slope
COST_OBS = 254  # obstacle in the translated array (never entered)
COST_OBS_ROS = 253  # costmap costs >= this are obstacles
COST_UNKNOWN_ROS = 255
PATH_STEP = 0.5  # gradient descent step [cells]

# Propagation goes on past the goal until the popped potential exceeds the goal's by this
# much, so the goal's 3 x 3 neighbourhood has final potentials for the descent's first step.
_GOAL_MARGIN = 2.0 * COST_OBS


def cost_translation_table(allow_unknown=True):
    """256-entry ``uint8`` table: costmap cost -> navfn traversal cost (see the module doc)."""
    c = np.arange(256, dtype=np.int64)
    table = np.where(c < COST_OBS_ROS, np.minimum(COST_NEUTRAL + COST_FACTOR * c, COST_OBS - 1), COST_OBS)
    if allow_unknown:
        table[COST_UNKNOWN_ROS] = COST_OBS - 1
    return table.astype(np.uint8)


def translate_costs(costs, allow_unknown=True, robot_cell=None):
    """navfn traversal costs of a ``uint8`` costmap array ``costs[my, mx]``.

    Obstacles (and the outer ring of cells) are ``COST_OBS``; ``robot_cell`` = (mx, my), if
    given, is set to ``COST_NEUTRAL``.
    """
    out = cost_translation_table(allow_unknown)[np.asarray(costs, dtype=np.uint8)]
    out[0, :] = COST_OBS
    out[-1, :] = COST_OBS
    out[:, 0] = COST_OBS
    out[:, -1] = COST_OBS
    if robot_cell is not None:
        out[robot_cell[1], robot_cell[0]] = COST_NEUTRAL
    return out


@numba.njit(cache=True)
def _cell_update(pot, cost, j, nx):
    """navfn's updateCell value for interior cell j (flat index) from its 4 neighbours."""
    left = pot[j - 1]
    right = pot[j + 1]
    up = pot[j - nx]
    down = pot[j + nx]
    tc = left if left < right else right
    ta = up if up < down else down
    hf = np.float32(cost[j])
    dc = tc - ta
    if dc < 0:
        dc = -dc
        ta = tc
    if dc >= hf:  # also when one of them is inf
        return ta + hf
    d = dc / hf
    return ta + hf * (np.float32(-0.2301) * d * d + np.float32(0.5307) * d + np.float32(0.7040))


@numba.njit(cache=True)
def _propagate(cost, start_x, start_y, goal_x, goal_y, margin):
    """Potential ``float32[ny, nx]`` (inf where unreached) grown from (start_x, start_y).

    Stops once the potential of the goal cell is final and the wave is ``margin`` beyond it;
    ``goal_x < 0`` propagates over everything reachable.
    """
    ny, nx = cost.shape
    n = nx * ny
    c = cost.ravel()
    pot = np.full(n, np.inf, dtype=np.float32)
    done = np.zeros(n, dtype=np.bool_)
    cap = 4096
    cap = max(cap, n // 16)
    hkey = np.empty(cap, dtype=np.float32)
    hidx = np.empty(cap, dtype=np.int32)
    size = 0
    goal = goal_y * nx + goal_x if goal_x >= 0 else -1
    start = start_y * nx + start_x
    stop_at = np.float32(np.inf)

    pot[start] = 0.0
    hkey[0] = 0.0
    hidx[0] = start
    size = 1
    while size > 0:
        # pop the minimum
        key = hkey[0]
        i = hidx[0]
        size -= 1
        if size > 0:
            lk = hkey[size]
            li = hidx[size]
            pos = 0
            while True:
                child = 2 * pos + 1
                if child >= size:
                    break
                if child + 1 < size and hkey[child + 1] < hkey[child]:
                    child += 1
                if hkey[child] >= lk:
                    break
                hkey[pos] = hkey[child]
                hidx[pos] = hidx[child]
                pos = child
            hkey[pos] = lk
            hidx[pos] = li
        if done[i] or key > pot[i]:
            continue  # stale entry
        if key > stop_at:
            break
        done[i] = True
        if i == goal:
            stop_at = key + np.float32(margin)
        ix = i % nx
        iy = i // nx
        for k in range(4):
            if k == 0:
                if ix == 0:
                    continue
                j = i - 1
            elif k == 1:
                if ix == nx - 1:
                    continue
                j = i + 1
            elif k == 2:
                if iy == 0:
                    continue
                j = i - nx
            else:
                if iy == ny - 1:
                    continue
                j = i + nx
            # only interior cells are below COST_OBS (the ring is COST_OBS), except the start
            if done[j] or c[j] >= COST_OBS:
                continue
            new = _cell_update(pot, c, j, nx)
            if new < pot[j]:
                pot[j] = new
                if size == cap:
                    cap *= 2
                    nk = np.empty(cap, dtype=np.float32)
                    ni = np.empty(cap, dtype=np.int32)
                    nk[:size] = hkey[:size]
                    ni[:size] = hidx[:size]
                    hkey = nk
                    hidx = ni
                pos = size
                size += 1
                while pos > 0:
                    parent = (pos - 1) // 2
                    if hkey[parent] <= new:
                        break
                    hkey[pos] = hkey[parent]
                    hidx[pos] = hidx[parent]
                    pos = parent
                hkey[pos] = new
                hidx[pos] = j
    return pot.reshape(ny, nx)


@numba.njit(cache=True)
def _cell_gradient(p, n, nx, ny):
    """navfn's gradCell: unit downhill direction (gx, gy) at cell n from its finite neighbours."""
    cv = p[n]
    x = n % nx
    y = n // nx
    dx = 0.0
    dy = 0.0
    if cv < np.inf:
        if x > 0 and p[n - 1] < np.inf:
            dx += p[n - 1] - cv
        if x < nx - 1 and p[n + 1] < np.inf:
            dx += cv - p[n + 1]
        if y > 0 and p[n - nx] < np.inf:
            dy += p[n - nx] - cv
        if y < ny - 1 and p[n + nx] < np.inf:
            dy += cv - p[n + nx]
    else:  # in an obstacle: push towards a side with a potential
        if x > 0 and p[n - 1] < np.inf:
            dx = -float(COST_OBS)
        elif x < nx - 1 and p[n + 1] < np.inf:
            dx = float(COST_OBS)
        if y > 0 and p[n - nx] < np.inf:
            dy = -float(COST_OBS)
        elif y < ny - 1 and p[n + nx] < np.inf:
            dy = float(COST_OBS)
    norm = math.hypot(dx, dy)
    if norm > 0.0:
        return dx / norm, dy / norm
    return 0.0, 0.0


@numba.njit(cache=True)
def _descend(potential, from_x, from_y, max_steps):
    """Path (cell coordinates, cell centres at integers) from the point (from_x, from_y) [cells]
    down to the potential's zero cell. Returns (xs, ys, ok)."""
    ny, nx = potential.shape
    p = potential.ravel()
    cap = 1024
    xs = np.empty(cap, dtype=np.float64)
    ys = np.empty(cap, dtype=np.float64)
    npath = 0
    px = float(from_x)
    py = float(from_y)
    for _ in range(max_steps):
        cx = min(max(math.floor(px + 0.5), 0), nx - 1)
        cy = min(max(math.floor(py + 0.5), 0), ny - 1)
        c = cy * nx + cx
        if npath + 1 >= cap:
            cap *= 2
            nxs = np.empty(cap, dtype=np.float64)
            nys = np.empty(cap, dtype=np.float64)
            nxs[:npath] = xs[:npath]
            nys[:npath] = ys[:npath]
            xs = nxs
            ys = nys
        if p[c] < COST_NEUTRAL:  # only the zero cell is below COST_NEUTRAL
            xs[npath] = cx
            ys[npath] = cy
            npath += 1
            return xs[:npath], ys[:npath], True
        xs[npath] = px
        ys[npath] = py
        npath += 1
        oscillating = npath > 2 and xs[npath - 1] == xs[npath - 3] and ys[npath - 1] == ys[npath - 3]
        interior = cx > 0 and cy > 0 and cx < nx - 1 and cy < ny - 1
        all_finite = interior
        if interior:
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    if not p[c + dy * nx + dx] < np.inf:
                        all_finite = False
        gx = 0.0
        gy = 0.0
        if all_finite and not oscillating:
            x0 = math.floor(px)
            y0 = math.floor(py)
            fx = px - x0
            fy = py - y0
            n00 = y0 * nx + x0
            g00x, g00y = _cell_gradient(p, n00, nx, ny)
            g10x, g10y = _cell_gradient(p, n00 + 1, nx, ny)
            g01x, g01y = _cell_gradient(p, n00 + nx, nx, ny)
            g11x, g11y = _cell_gradient(p, n00 + nx + 1, nx, ny)
            gx = (1 - fy) * ((1 - fx) * g00x + fx * g10x) + fy * ((1 - fx) * g01x + fx * g11x)
            gy = (1 - fy) * ((1 - fx) * g00y + fx * g10y) + fy * ((1 - fx) * g01y + fx * g11y)
        g = math.hypot(gx, gy)
        if g > 1e-6:
            px += PATH_STEP * gx / g
            py += PATH_STEP * gy / g
        else:  # follow the grid: lowest of the 8 neighbours, which must be lower than here
            best = c
            best_p = p[c]
            for dy in range(-1, 2):
                yy = cy + dy
                if yy < 0 or yy >= ny:
                    continue
                for dx in range(-1, 2):
                    xx = cx + dx
                    if xx < 0 or xx >= nx:
                        continue
                    q = yy * nx + xx
                    if p[q] < best_p:
                        best_p = p[q]
                        best = q
            if best == c:
                return xs[:npath], ys[:npath], False
            px = float(best % nx)
            py = float(best // nx)
    return xs[:npath], ys[:npath], False


def compute_potential(traversal_costs, robot_cell, goal_cell=None):
    """navfn potential ``float32[ny, nx]`` (0 at ``robot_cell`` = (mx, my), inf where not reached).

    ``traversal_costs`` is a :func:`translate_costs` array. With ``goal_cell`` = (mx, my) the
    wave stops a little past the goal; without it, it covers everything reachable.
    """
    cost = np.ascontiguousarray(traversal_costs, dtype=np.uint8)
    gx, gy = (-1, -1) if goal_cell is None else goal_cell
    return _propagate(cost, int(robot_cell[0]), int(robot_cell[1]), int(gx), int(gy), _GOAL_MARGIN)


def descend_potential(potential, from_point, max_steps=None):
    """Path (N, 2) in cell coordinates (cell (mx, my)'s centre at (mx, my)) from ``from_point`` =
    (x, y) [cells] down to the potential's zero cell, or ``None`` when the descent gets stuck."""
    potential = np.ascontiguousarray(potential, dtype=np.float32)
    if max_steps is None:
        max_steps = 2 * potential.size + 16
    xs, ys, ok = _descend(potential, float(from_point[0]), float(from_point[1]), int(max_steps))
    if not ok:
        return None
    return np.column_stack((xs, ys))


@dataclasses.dataclass
class PlanResult:
    """A planning answer.

    ok: a plan was found.
    poses: (N, 3) array of (x [m], y [m], yaw [rad]) in the costmap's frame, robot -> goal; empty
        when not ok.
    reason: why planning failed ('' when ok).
    potential: navfn potential over the costmap ``float32[size_y, size_x]`` (traversal cost x
        cells, 0 at the robot, inf where not reached), or None when none was computed.
    """

    ok: bool
    poses: np.ndarray
    reason: str = ""
    potential: np.ndarray = None


def _fail(reason, potential=None):
    log.debug("navfn: %s", reason)
    return PlanResult(False, np.empty((0, 3)), reason, potential)


PARAMS = ParamTable(
    Param("allow_unknown", bool, True, "unknown cells (255) are passable at traversal cost 253"),
    Param("default_tolerance", float, 0.0, "goal tolerance used when a plan request gives none", unit="m", ge=0.0),
    Param("planner_window_x", float, 0.0, "width of the searched window round the robot (0: the whole costmap; "
          "used with planner_window_y)", unit="m", ge=0.0),
    Param("planner_window_y", float, 0.0, "height of the searched window round the robot (0: the whole costmap)",
          unit="m", ge=0.0),
    Param("visualize_potential", bool, False, "recorded only: every PlanResult carries the potential anyway"),
)
"""NavfnROS's parameters (``~NavfnROS/``: names and defaults of ROS's navfn)."""


class NavfnPlanner:
    """NavfnROS's makePlan on a :class:`~move_base.costmap_2d.Costmap2D`.

    Keyword arguments: :data:`PARAMS` (NavfnROS's ``~NavfnROS/*`` names and defaults); a value out of
    range raises ParamError (a ValueError) naming it. With planner_window_x and planner_window_y
    both > 0, only the window of that size centred on the robot's cell (clipped to the costmap) is
    searched, its edge cells being walls like the costmap's; a goal outside it fails.
    """

    def __init__(self, **params):
        p = PARAMS.validate(params)
        self.allow_unknown = p.allow_unknown
        self.default_tolerance = p.default_tolerance
        self.planner_window_x = p.planner_window_x
        self.planner_window_y = p.planner_window_y
        self.visualize_potential = p.visualize_potential

    def _window(self, costmap, robot_cell):
        """Cell bounds (x0, y0, x1, y1), end exclusive, of the area searched."""
        if self.planner_window_x <= 0.0 or self.planner_window_y <= 0.0:
            return 0, 0, costmap.size_x, costmap.size_y
        hx = math.ceil(0.5 * self.planner_window_x / costmap.resolution)
        hy = math.ceil(0.5 * self.planner_window_y / costmap.resolution)
        mx, my = robot_cell
        return (max(mx - hx, 0), max(my - hy, 0), min(mx + hx + 1, costmap.size_x), min(my + hy + 1, costmap.size_y))

    def make_plan(self, costmap, start, goal, tolerance=None, start_clearance=0.0):
        """Plan from ``start`` = (x [m], y [m], yaw [rad]) to ``goal`` (same) on ``costmap``.

        ``tolerance`` [m] (``default_tolerance`` when None): if the goal itself has no potential
        (obstacle, unreachable), the reachable point of the square ``goal +- tolerance`` sampled
        at the costmap's resolution closest to the goal is planned to instead.
        ``start_clearance`` [m] (Florence): cells within it of the start that are inscribed (253,
        not lethal) are passable at the highest traversal cost, so a robot whose centre stands in
        the inflated ring of a wall or a person (its outline clear of them, as the local planner
        allows) can still plan its way out; ROS frees the robot's cell only, and its neighbours
        then wall it in.

        Returns a :class:`PlanResult`; the costmap is not modified.
        """
        tol = self.default_tolerance if tolerance is None else float(tolerance)
        sx, sy = float(start[0]), float(start[1])
        gx, gy, gyaw = float(goal[0]), float(goal[1]), float(goal[2])
        robot_cell = costmap.world_to_map(sx, sy)
        if robot_cell is None:
            return _fail(f"the robot's start ({sx:.2f}, {sy:.2f}) is off the global costmap")
        goal_cell = costmap.world_to_map(gx, gy)
        if goal_cell is None and tol <= 0.0:
            return _fail(f"the goal ({gx:.2f}, {gy:.2f}) is off the global costmap")

        x0, y0, x1, y1 = self._window(costmap, robot_cell)
        in_window = goal_cell is not None and x0 <= goal_cell[0] < x1 and y0 <= goal_cell[1] < y1
        if goal_cell is not None and not in_window:
            return _fail(f"the goal ({gx:.2f}, {gy:.2f}) is outside the planner window "
                         f"({self.planner_window_x:.2f} x {self.planner_window_y:.2f} m around the robot)")
        rcell = (robot_cell[0] - x0, robot_cell[1] - y0)
        trav = translate_costs(costmap.costs[y0:y1, x0:x1], self.allow_unknown, rcell)
        if start_clearance > 0.0:
            _open_start(trav, costmap.costs[y0:y1, x0:x1], rcell, start_clearance / costmap.resolution)
        # the wave may stop early only when the goal cell can get a potential
        target = None
        if goal_cell is not None and trav[goal_cell[1] - y0, goal_cell[0] - x0] < COST_OBS:
            target = (goal_cell[0] - x0, goal_cell[1] - y0)
        pot_win = compute_potential(trav, rcell, target)
        if (x0, y0, x1, y1) == (0, 0, costmap.size_x, costmap.size_y):
            potential = pot_win
        else:
            potential = np.full(costmap.costs.shape, np.inf, dtype=np.float32)
            potential[y0:y1, x0:x1] = pot_win

        # the end of the plan: the goal, else the closest reachable point within tolerance
        if goal_cell is not None and np.isfinite(potential[goal_cell[1], goal_cell[0]]):
            end = (gx, gy)
        else:
            end = self._nearest_reachable(costmap, potential, gx, gy, tol)
            if end is None:
                return _fail(self._unreachable_reason(costmap, (sx, sy), (gx, gy), goal_cell, tol), potential)

        # the descent starts at the end point itself, in window cell coordinates
        end_px = (end[0] - costmap.origin_x) / costmap.resolution - 0.5 - x0
        end_py = (end[1] - costmap.origin_y) / costmap.resolution - 0.5 - y0
        cells = descend_potential(pot_win, (end_px, end_py))
        if cells is None:
            return _fail(f"no path from ({sx:.2f}, {sy:.2f}) to ({gx:.2f}, {gy:.2f}): gradient descent on "
                         "the potential got stuck", potential)
        cells = cells[::-1]  # robot -> end
        wx, wy = costmap.map_to_world(cells[:, 0] + x0, cells[:, 1] + y0)
        # the robot's exact position instead of its cell's centre
        xs = np.concatenate(([sx], wx[1:-1], [end[0]]))
        ys = np.concatenate(([sy], wy[1:-1], [end[1]]))
        return PlanResult(True, _with_headings(xs, ys, gyaw), "", potential)

    def _unreachable_reason(self, costmap, start, goal, goal_cell, tol):
        """Why no point within ``tol`` [m] of ``goal`` = (x, y) [m] got a potential."""
        (sx, sy), (gx, gy) = start, goal
        within = f" and no point within {tol:.2f} m of it is reachable" if tol > 0.0 else ""
        if goal_cell is None:
            return f"the goal ({gx:.2f}, {gy:.2f}) is off the global costmap{within}"
        cost = int(costmap.costs[goal_cell[1], goal_cell[0]])
        blocked = cost >= INSCRIBED_INFLATED_OBSTACLE and not (cost == NO_INFORMATION and self.allow_unknown)
        if blocked:
            return f"the goal ({gx:.2f}, {gy:.2f}) is in an obstacle (cost {cost}){within}"
        return f"no path from ({sx:.2f}, {sy:.2f}) to ({gx:.2f}, {gy:.2f}){within}"

    @staticmethod
    def _nearest_reachable(costmap, potential, gx, gy, tol):
        """NavfnROS's tolerance search: the point (x, y) [m] of the grid ``goal + k * resolution``
        in ``[-tol, tol]^2`` with a finite potential closest to the goal, or None."""
        if tol <= 0.0:
            return None
        res = costmap.resolution
        k = math.floor(2.0 * tol / res + 1e-9)
        offsets = -tol + res * np.arange(k + 1)
        ox, oy = np.meshgrid(offsets, offsets)
        px = gx + ox.ravel()
        py = gy + oy.ravel()
        mx, my, inside = costmap.world_to_map(px, py)
        reachable = np.zeros(px.shape, dtype=bool)
        reachable[inside] = np.isfinite(potential[my[inside], mx[inside]])
        if not reachable.any():
            return None
        d2 = np.where(reachable, (px - gx) ** 2 + (py - gy) ** 2, np.inf)
        best = int(np.argmin(d2))
        return float(px[best]), float(py[best])


def _open_start(trav, costs, cell, radius_cells):
    """Make the inscribed cells (253) of ``costs`` within ``radius_cells`` of ``cell`` passable in
    the traversal costs ``trav`` (in place), at COST_OBS - 1."""
    r = math.ceil(radius_cells)
    x0, y0 = max(cell[0] - r, 0), max(cell[1] - r, 0)
    x1, y1 = min(cell[0] + r + 1, costs.shape[1] - 1), min(cell[1] + r + 1, costs.shape[0] - 1)
    x0, y0 = max(x0, 1), max(y0, 1)  # the outer ring stays an obstacle
    if x0 >= x1 or y0 >= y1:
        return
    ys, xs = np.mgrid[y0:y1, x0:x1]
    near = (xs - cell[0]) ** 2 + (ys - cell[1]) ** 2 <= radius_cells * radius_cells
    near &= costs[y0:y1, x0:x1] == INSCRIBED_INFLATED_OBSTACLE
    trav[y0:y1, x0:x1][near] = COST_OBS - 1


def _with_headings(xs, ys, goal_yaw):
    """(N, 3) poses: each yaw [rad] points at the next distinct point; the last has ``goal_yaw``."""
    dx = np.diff(xs)
    dy = np.diff(ys)
    yaw = np.arctan2(dy, dx)
    moving = np.hypot(dx, dy) > 1e-9
    if len(yaw):
        # a repeated point keeps the heading of the next real step (or the goal's)
        idx = np.where(moving, np.arange(len(yaw)), len(yaw))
        idx = np.minimum.accumulate(idx[::-1])[::-1]
        yaw = np.append(yaw, goal_yaw)[idx]
    return np.column_stack((xs, ys, np.append(yaw, goal_yaw)))


def path_cost(costmap, xy, allow_unknown=True, start_clearance=0.0):
    """navfn's traversal cost of following the polyline ``xy`` (N, 2+) [m] on ``costmap``: the
    translated cost of the cell under each half-cell step, times the step in cells (the units of
    the potential: traversal cost x cells; a free metre costs ``COST_NEUTRAL / resolution``).
    ``inf`` when the path leaves the costmap or crosses an obstacle. The cells round the first
    point are treated as :meth:`NavfnPlanner.make_plan` treats the robot's (its own cell free,
    inscribed cells within ``start_clearance`` [m] passable), so a kept plan and a new one from
    the same robot pose are costed alike."""
    xy = np.asarray(xy, dtype=float)
    if xy.ndim != 2 or len(xy) == 0 or xy.shape[1] < 2 or not np.isfinite(xy[:, :2]).all():
        return math.inf
    trav = _start_costs(costmap, xy[0], allow_unknown, start_clearance)
    return math.inf if trav is None else _cost_along(costmap, trav, xy[:, :2])


def _start_costs(costmap, start_xy, allow_unknown, start_clearance):
    """Translated costs with the start treated as make_plan treats the robot's; None off the map."""
    start = costmap.world_to_map(float(start_xy[0]), float(start_xy[1]))
    if start is None:
        return None
    trav = translate_costs(costmap.costs, allow_unknown, start)
    if start_clearance > 0.0:
        _open_start(trav, costmap.costs, start, start_clearance / costmap.resolution)
    return trav


def _cost_along(costmap, trav, xy):
    """path_cost on translated costs ``trav``."""
    seg = np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))
    s = np.concatenate(([0.0], np.cumsum(seg)))
    total = s[-1] / costmap.resolution  # [cells]
    if total <= 0.0:
        return 0.0
    n = math.ceil(total / PATH_STEP)
    at = (np.arange(n) + 0.5) * (s[-1] / n)
    mx, my, inside = costmap.world_to_map(np.interp(at, s, xy[:, 0]), np.interp(at, s, xy[:, 1]))
    if not inside.all():
        return math.inf
    cells = trav[my, mx].astype(float)
    if (cells >= COST_OBS).any():
        return math.inf
    return float(cells.sum() * (total / n))


def _distances_to(points, path):
    """(N,) distance [m] from each of ``points`` (N, 2+) to the nearest point of ``path`` (M, 2+)."""
    from scipy.spatial import cKDTree

    return cKDTree(np.asarray(path, dtype=float)[:, :2]).query(np.asarray(points, dtype=float)[:, :2])[0]


def plans_apart(a, b, step=4):
    """How far [m] plan ``a`` (N, 2+) strays from plan ``b`` (M, 2+): the largest distance from a
    point of ``a`` (every ``step``-th, and its last) to the nearest point of ``b``."""
    a = np.asarray(a, dtype=float)
    return float(_distances_to(np.vstack((a[::step], a[-1:])), b).max())


def keep_current_plan(costmap, current, new, robot_xy, keep_ratio, keep_margin, max_offset=0.5, search=2.0,
                      same_way=1.0, people=None, people_radius=1.5, allow_unknown=True, start_clearance=0.0):
    """Replanning hysteresis (Florence; ROS's move_base takes every new plan). A home is full of
    loops (round the dining table, through either door of a room): two ways to a goal can cost
    nearly the same, and a plan made once a second from a robot that has moved a little may swap
    between them, turning the robot back and forth (florence_sim, nobody home: a leg that set off
    one way, turned on the spot and went the other way lost 4-10 s).

    ``current`` (N, 3) is the plan being followed (pruned as the robot advanced), ``new`` the plan
    just made from ``robot_xy`` (x, y) [m] to the same goal. When the new plan goes another way
    (it strays more than ``same_way`` [m] from the current one's rest, :func:`plans_apart`),
    returns the rest of ``current`` from its pose nearest the robot (within the first ``search``
    [m] of it, at most ``max_offset`` [m] away), with the robot's position put first, when its
    :func:`path_cost` is at most ``(1 + keep_ratio)`` times the new plan's plus ``keep_margin`` [m]
    of free cells; else None (take the new plan: the fresh plan the same way, which starts where
    the robot is, or a way that costs enough less). A kept plan through an obstacle, a person's
    inscribed ring or off the map costs ``inf`` and is never kept; nor is one that passes within
    ``people_radius`` [m] of any of ``people`` (P, 2+) [m] (those the costmaps hold, what may be a
    person): round people the plan follows their proxemic costs as they move, as without
    hysteresis."""
    current = np.asarray(current, dtype=float).reshape(-1, 3)
    new = np.asarray(new, dtype=float).reshape(-1, 3)
    if len(current) < 2 or len(new) < 2 or (keep_ratio <= 0.0 and keep_margin <= 0.0):
        return None
    rest = _rest_of_plan(current, robot_xy, max_offset, search)
    if rest is None or plans_apart(new, rest) <= same_way:
        return None
    if people is not None and len(people) and _distances_to(people, rest).min() <= people_radius:
        return None
    trav = _start_costs(costmap, robot_xy, allow_unknown, start_clearance)
    old_cost = math.inf if trav is None else _cost_along(costmap, trav, rest[:, :2])
    if not math.isfinite(old_cost):
        return None
    margin = keep_margin / costmap.resolution * COST_NEUTRAL
    if old_cost > (1.0 + keep_ratio) * _cost_along(costmap, trav, new[:, :2]) + margin:
        return None
    return _with_headings(rest[:, 0], rest[:, 1], float(current[-1, 2]))


def _rest_of_plan(plan, robot_xy, max_offset, search):
    """The robot's position (x, y, 0) followed by ``plan`` from its pose nearest the robot among
    those within ``search`` [m] along it from its start; None when that pose is more than
    ``max_offset`` [m] away or the plan is not finite."""
    along = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(plan[:, 0]), np.diff(plan[:, 1])))))
    head = plan[along <= search]  # along[0] is 0: never empty
    d = np.hypot(head[:, 0] - robot_xy[0], head[:, 1] - robot_xy[1])
    k = int(np.nanargmin(d)) if np.isfinite(d).any() else 0
    if not d[k] <= max_offset:
        return None
    rest = np.vstack(([robot_xy[0], robot_xy[1], 0.0], plan[k:] if d[k] > 1e-9 else plan[k + 1:]))
    return rest if np.isfinite(rest[:, :2]).all() else None
