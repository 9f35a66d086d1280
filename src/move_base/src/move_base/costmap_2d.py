"""A 2-D cost grid with costmap_2d's cost values and cell conventions (ROS-free).

Cell (mx, my) covers world x in [origin_x + mx * resolution, origin_x + (mx + 1) * resolution)
and likewise in y; ``costs[my, mx]`` is its cost (row-major, the order of
``nav_msgs/OccupancyGrid.data``). Costs are costmap_2d's: 0 free, 1..252 inflated,
253 inscribed (the robot's centre here means a collision), 254 lethal, 255 unknown.
"""

import logging

import numpy as np

log = logging.getLogger(__name__)

FREE_SPACE = 0
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255


class Costmap2D:
    """The grid: geometry plus a ``uint8`` cost array ``costs[my, mx]``.

    Attributes:
        resolution: cell side [m].
        origin_x, origin_y: world position of the corner of cell (0, 0) [m].
        costs: ``np.ndarray`` of ``uint8``, shape (size_y, size_x).
        default_value: cost of a cell nobody has written (FREE_SPACE or NO_INFORMATION).
    """

    def __init__(self, size_x, size_y, resolution, origin_x=0.0, origin_y=0.0, default_value=FREE_SPACE):
        if size_x <= 0 or size_y <= 0:
            raise ValueError(f"costmap size must be positive, got {size_x} x {size_y} cells")
        if not resolution > 0.0:
            raise ValueError(f"costmap resolution must be positive, got {resolution}")
        self.resolution = float(resolution)
        self.origin_x = float(origin_x)
        self.origin_y = float(origin_y)
        self.default_value = int(default_value)
        self.costs = np.full((int(size_y), int(size_x)), self.default_value, dtype=np.uint8)

    @property
    def size_x(self):
        return self.costs.shape[1]

    @property
    def size_y(self):
        return self.costs.shape[0]

    @property
    def size_m(self):
        """(width, height) of the grid [m]."""
        return self.size_x * self.resolution, self.size_y * self.resolution

    def copy(self):
        other = Costmap2D(self.size_x, self.size_y, self.resolution, self.origin_x, self.origin_y, self.default_value)
        other.costs[...] = self.costs
        return other

    def resize(self, size_x, size_y, resolution, origin_x, origin_y):
        """New geometry, every cell back to the default value."""
        self.resolution = float(resolution)
        self.origin_x = float(origin_x)
        self.origin_y = float(origin_y)
        self.costs = np.full((int(size_y), int(size_x)), self.default_value, dtype=np.uint8)

    # --- coordinates -------------------------------------------------------------------------
    def world_to_map(self, wx, wy):
        """Cell indices (mx, my) of world point(s) [m]; ``None`` for a scalar point off the grid.

        With arrays, returns integer arrays (cells off the grid included) and a boolean mask of
        the points on the grid.
        """
        fx = (np.asarray(wx, dtype=float) - self.origin_x) / self.resolution
        fy = (np.asarray(wy, dtype=float) - self.origin_y) / self.resolution
        mx = np.floor(fx).astype(np.int64)
        my = np.floor(fy).astype(np.int64)
        inside = (mx >= 0) & (my >= 0) & (mx < self.size_x) & (my < self.size_y)
        if np.ndim(wx) == 0 and np.ndim(wy) == 0:
            return (int(mx), int(my)) if bool(inside) else None
        return mx, my, inside

    def map_to_world(self, mx, my):
        """World position [m] of the centre of cell(s) (mx, my)."""
        wx = self.origin_x + (np.asarray(mx, dtype=float) + 0.5) * self.resolution
        wy = self.origin_y + (np.asarray(my, dtype=float) + 0.5) * self.resolution
        if np.ndim(wx) == 0:
            return float(wx), float(wy)
        return wx, wy

    def cost_at(self, wx, wy):
        """Cost of the cell holding world point (wx, wy), NO_INFORMATION off the grid."""
        cell = self.world_to_map(wx, wy)
        if cell is None:
            return NO_INFORMATION
        return int(self.costs[cell[1], cell[0]])

    def contains(self, wx, wy):
        return self.world_to_map(wx, wy) is not None

    # --- added for the layers (move_base.layers) ---------------------------------------------
    def world_to_map_no_bounds(self, wx, wy):
        """Cell indices of world point (wx, wy) [m] without a bounds check, truncated towards zero
        as costmap_2d's worldToMapNoBounds does (``(int)((wx - origin_x) / resolution)``)."""
        return int((wx - self.origin_x) / self.resolution), int((wy - self.origin_y) / self.resolution)

    def update_origin(self, new_origin_x, new_origin_y):
        """Move the grid to a new origin [m], keeping the costs of the cells that stay on it
        (costmap_2d's updateOrigin): the origin moves by whole cells (the shift is truncated
        towards zero), the cells that come new onto the grid take the default value."""
        cell_ox = int((new_origin_x - self.origin_x) / self.resolution)
        cell_oy = int((new_origin_y - self.origin_y) / self.resolution)
        if cell_ox == 0 and cell_oy == 0:
            return
        old = self.costs
        self.costs = np.full_like(old, self.default_value)
        sx, sy = self.size_x, self.size_y
        # overlap in old-cell indices: [lo, hi) on each axis
        lo_x, hi_x = max(0, cell_ox), min(sx, sx + cell_ox)
        lo_y, hi_y = max(0, cell_oy), min(sy, sy + cell_oy)
        if lo_x < hi_x and lo_y < hi_y:
            self.costs[lo_y - cell_oy : hi_y - cell_oy, lo_x - cell_ox : hi_x - cell_ox] = old[lo_y:hi_y, lo_x:hi_x]
        self.origin_x += cell_ox * self.resolution
        self.origin_y += cell_oy * self.resolution
