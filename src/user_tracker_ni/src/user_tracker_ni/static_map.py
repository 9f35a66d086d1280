"""The robot's map as prior knowledge for the tracker (no ROS): nobody stands inside a wall.

Users of ROS people trackers complain most of ghost tracks on walls and furniture, and the
remedy their maintainers give is a prior map. With the map the robot navigates by (map_server's
occupancy grid, placed through amcl's map -> odom), a detection whose centre lies on a *thin*
static structure (a wall, a door frame's end, a lamp's or coat stand's pole, a plant's pot) is
no person: such detections neither start tracks nor confirm them. Thick furniture is not ruled
out, since people sit on sofas and beds and lean over counters: a structure counts as thin where
its occupied cells lie within ``thin`` of free space (a wall 10 cm thick, a pot 36 cm across are
thin; a sofa 0.9 m deep is not).
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage


@dataclass(frozen=True)
class StaticMapParams:
    clearance: float = 0.10  # [m] a detection this near a thin structure's cells is on it
    thin: float = 0.2  # [m] occupied cells at most this far from free space are thin structure
    occupied: int = 65  # occupancy value [0..100] from which a cell is occupied (map_server's 0.65)

    def validate(self):
        if not (self.clearance >= 0 and self.thin > 0 and 0 < self.occupied <= 100):
            raise ValueError("need clearance >= 0, thin > 0 and 0 < occupied <= 100")
        return self


class StaticMap:
    """``grid``: occupancy [height, width] (-1 unknown, 0..100) as nav_msgs/OccupancyGrid holds
    it (row 0 at the origin, x along columns); ``resolution`` [m/cell]; ``origin``: (x, y, yaw)
    of cell (0, 0)'s corner in the map frame."""

    def __init__(self, grid, resolution, origin, params=None):
        self.p = (params or StaticMapParams()).validate()
        grid = np.asarray(grid)
        if grid.ndim != 2 or grid.size == 0 or not resolution > 0:
            raise ValueError(f"map of shape {grid.shape} and resolution {resolution}: not a usable grid")
        self.resolution = float(resolution)
        x, y, yaw = (float(v) for v in origin)
        c, s = np.cos(yaw), np.sin(yaw)
        self.to_grid = np.linalg.inv(np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]]))
        occupied = grid >= self.p.occupied
        # distance [m] of each occupied cell to the nearest free (or unknown) one
        depth = ndimage.distance_transform_edt(occupied) * self.resolution
        thin = occupied & (depth <= self.p.thin)
        # thick structure rules its thin rim out too (the edge of a sofa is part of the sofa)
        thick = ndimage.binary_dilation(occupied & (depth > self.p.thin),
                                        iterations=max(1, int(np.ceil(self.p.thin / self.resolution))))
        thin &= ~thick
        # distance [m] of every cell to the nearest thin structure
        self.distance = ndimage.distance_transform_edt(~thin) * self.resolution
        self.shape = grid.shape

    def on_structure(self, xy_map):
        """Boolean [N]: the points [N, 2] (map frame) lie on (within ``clearance`` of) thin static
        structure. Points off the map: False."""
        xy = np.asarray(xy_map, float).reshape(-1, 2)
        if len(xy) == 0:
            return np.zeros(0, bool)
        g = xy @ self.to_grid[:2, :2].T + self.to_grid[:2, 2]
        col = np.floor(g[:, 0] / self.resolution).astype(np.int64)
        row = np.floor(g[:, 1] / self.resolution).astype(np.int64)
        inside = (row >= 0) & (row < self.shape[0]) & (col >= 0) & (col < self.shape[1])
        out = np.zeros(len(xy), bool)
        out[inside] = self.distance[row[inside], col[inside]] <= self.p.clearance
        return out
