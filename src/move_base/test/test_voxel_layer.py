"""The voxel layer (costmap_2d VoxelLayer, map_type voxel): marking between the height limits,
clearing per column and height along each ray, rays beyond range, bad points, the rolling
window, resets; and the LayeredCostmap it sits in."""

import math

import numpy as np
import pytest
from move_base.costmap_2d import FREE_SPACE, LETHAL_OBSTACLE, Costmap2D
from move_base.layers import LayeredCostmap, ObservationSource
from move_base.voxel_layer import VoxelLayer, popcount32

pytestmark = pytest.mark.unit

KINECT = (0.0, 0.0, 0.54)  # [m] the camera's height on the Florence TurtleBot
LASER = (0.0, 0.0, 0.165)  # [m] the Hokuyo's


def layer(**kw):
    """A voxel layer of 5 cm voxels to 1.0 m over a 4 x 4 m grid centred on the origin, with a
    Kinect source (marks 0.05..1.0 m) and a laser source, both clearing."""
    sources = [
        ObservationSource("kinect", obstacle_range=2.5, raytrace_range=3.0, min_obstacle_height=0.05,
                          max_obstacle_height=1.0, clearing=True),
        ObservationSource("scan", obstacle_range=2.5, raytrace_range=3.0, max_obstacle_height=2.0, clearing=True),
    ]
    v = VoxelLayer(sources, origin_z=0.0, z_resolution=0.05, z_voxels=20, **kw)
    v.match_size(Costmap2D(80, 80, 0.05, -2.0, -2.0))
    return v


def table_top(x0, x1, y0, y1, z=0.69, step=0.02):
    """Points of a table top's underside [m]."""
    xs, ys = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
    return np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, z)])


def laser_fan(ranges_m, height=0.165, count=181):
    angles = np.linspace(-math.pi / 2, math.pi / 2, count)
    return np.column_stack([ranges_m * np.cos(angles), ranges_m * np.sin(angles), np.full(count, height)])


def test_popcount():
    bits = np.array([0, 1, 3, 0xFFFFFFFF, 0x80000001], dtype=np.uint32)
    assert popcount32(bits).tolist() == [0, 1, 2, 32, 2]


def test_table_top_seen_from_afar_stays_when_the_laser_passes_under_it():
    v = layer()
    # far: the Kinect sees the underside of a table top 0.7..1.5 m ahead
    v.add_observation("kinect", KINECT, table_top(0.7, 1.5, -0.4, 0.4), stamp=0.0)
    v.add_observation("scan", LASER, laser_fan(1.9), stamp=0.0)
    v.update()
    assert v.grid.cost_at(0.75, 0.0) == LETHAL_OBSTACLE
    assert v.grid.cost_at(1.2, 0.2) == LETHAL_OBSTACLE
    # near: the Kinect sees nothing (blind within ~0.5 m, every pixel NaN), the laser's beams run
    # under the table to the wall 1.9 m away: they clear at their own height only
    v.add_observation("kinect", KINECT, np.full((100, 3), np.nan), stamp=1.0)
    v.add_observation("scan", LASER, laser_fan(1.9), stamp=1.0)
    v.update()
    assert v.grid.cost_at(0.75, 0.0) == LETHAL_OBSTACLE
    assert v.grid.cost_at(1.2, 0.2) == LETHAL_OBSTACLE
    assert v.grid.cost_at(1.9, 0.0) == LETHAL_OBSTACLE  # the wall the laser hits
    assert v.grid.cost_at(0.5, 0.5) == FREE_SPACE


def test_a_2d_obstacle_layer_loses_that_table_top():
    """The same readings in ROS's 2-D obstacle layer: the laser's ray clears the column (the
    reason for the voxel layer)."""
    lay = LayeredCostmap(80, 80, 0.05, -2.0, -2.0, rolling_window=False, static_map=False,
                         sources=[ObservationSource("kinect", min_obstacle_height=0.05, max_obstacle_height=1.0,
                                                    clearing=True),
                                  ObservationSource("scan", clearing=True)])
    lay.obstacles.add_observation("kinect", KINECT, table_top(0.7, 1.5, -0.4, 0.4), stamp=0.0)
    lay.obstacles.update()
    assert lay.obstacles.grid.cost_at(0.75, 0.0) == LETHAL_OBSTACLE
    lay.obstacles.add_observation("kinect", KINECT, np.zeros((0, 3)), stamp=1.0)
    lay.obstacles.add_observation("scan", LASER, laser_fan(1.9), stamp=1.0)
    lay.obstacles.update()
    assert lay.obstacles.grid.cost_at(0.75, 0.0) == FREE_SPACE


def test_marks_only_between_the_height_limits_but_every_ray_clears():
    v = layer()
    floor = np.array([[1.0, 0.0, 0.01], [1.5, 0.5, -0.01]])  # the floor: below min_obstacle_height
    high = np.array([[1.0, -0.5, 1.2]])  # above max_obstacle_height (a picture on the wall)
    chair = np.array([[0.8, 0.6, 0.45]])
    v.add_observation("kinect", KINECT, np.vstack([floor, high, chair]), stamp=0.0)
    v.update()
    assert v.grid.cost_at(1.0, 0.0) == FREE_SPACE
    assert v.grid.cost_at(1.0, -0.5) == FREE_SPACE
    assert v.grid.cost_at(0.8, 0.6) == LETHAL_OBSTACLE
    # a box 0.6 m ahead, 0.3 m high, seen before; then the Kinect sees the floor behind it over the
    # place where the box was: the ray to the floor clears the voxels it passes (the box is gone)
    v.add_observation("kinect", KINECT, np.array([[0.6, 0.0, 0.3]]), stamp=1.0)
    v.update()
    assert v.grid.cost_at(0.6, 0.0) == LETHAL_OBSTACLE
    v.add_observation("kinect", KINECT, np.array([[1.0, 0.0, 0.0]]), stamp=2.0)  # the ray passes 0.6 m at 0.22 m
    v.update()
    assert v.grid.cost_at(0.6, 0.0) == LETHAL_OBSTACLE, "the ray passes 8 cm under the box's voxel"
    v.add_observation("kinect", KINECT, np.array([[0.9, 0.0, 0.18]]), stamp=3.0)  # through (0.6, 0.3)
    v.update()
    assert v.grid.cost_at(0.6, 0.0) == FREE_SPACE


def test_readings_beyond_range_clear_and_do_not_mark():
    v = layer()
    v.bits[v.grid.world_to_map(1.5, 0.0)[::-1]] = 1 << 3  # an old mark at 0.15..0.20 m
    v.add_observation("scan", LASER, np.array([[3.5, 0.0, 0.165]]), stamp=0.0)  # beyond obstacle_range
    v.update()
    assert v.grid.cost_at(1.5, 0.0) == FREE_SPACE  # cleared on the way (raytrace_range 3 m)
    assert int(v.bits.sum()) == 0  # nothing marked at 3.5 m (off the grid anyway) or nearer
    # a laser beam with no return (free_ends) clears raytrace_range at its height
    v.bits[v.grid.world_to_map(1.0, 1.0)[::-1]] = 1 << 3
    v.add_observation("scan", LASER, np.zeros((0, 3)), free_ends=np.array([[1.0, 1.0, 0.165]]), stamp=1.0)
    v.update()
    assert v.grid.cost_at(1.0, 1.0) == FREE_SPACE


def test_nan_and_inf_points_are_no_readings():
    v = layer()
    pts = np.array([[np.nan, 0.0, 0.3], [1.0, np.inf, 0.3], [0.7, 0.3, 0.3]])
    v.add_observation("kinect", KINECT, pts, stamp=0.0)
    v.update()
    assert int(np.count_nonzero(v.grid.costs == LETHAL_OBSTACLE)) == 1
    assert v.grid.cost_at(0.7, 0.3) == LETHAL_OBSTACLE


def test_mark_threshold_counts_the_voxels_of_a_column():
    v = layer(mark_threshold=1)
    v.add_observation("kinect", KINECT, np.array([[1.0, 0.0, 0.3], [0.5, 0.5, 0.3], [0.5, 0.5, 0.6]]), stamp=0.0)
    v.update()
    assert v.grid.cost_at(1.0, 0.0) == FREE_SPACE  # one voxel: not more than the threshold
    assert v.grid.cost_at(0.5, 0.5) == LETHAL_OBSTACLE


def test_rolling_window_moves_the_columns_with_the_costs():
    v = layer()
    v.add_observation("kinect", KINECT, np.array([[1.0, 0.5, 0.7]]), stamp=0.0)
    v.update()
    column = v.bits[v.grid.world_to_map(1.0, 0.5)[::-1]]
    v.update_origin(-1.5, -2.0)  # 0.5 m east
    v.buffers["kinect"].observations.clear()
    v.update()
    assert v.grid.cost_at(1.0, 0.5) == LETHAL_OBSTACLE
    assert v.bits[v.grid.world_to_map(1.0, 0.5)[::-1]] == column


def test_reset_clear_outside_and_footprint_empty_the_columns():
    v = layer()
    pts = np.array([[0.3, 0.0, 0.7], [1.5, 1.5, 0.7]])
    v.add_observation("kinect", (0.0, 0.0, 0.54), pts, stamp=0.0)
    v.update()
    v.buffers["kinect"].observations.clear()
    v.clear_outside(0.0, 0.0, 1.0)  # keep the 1 m square round the origin
    v.update()
    assert v.grid.cost_at(0.3, 0.0) == LETHAL_OBSTACLE and v.grid.cost_at(1.5, 1.5) == FREE_SPACE
    mx, my = v.grid.world_to_map(0.3, 0.0)
    v.clear_cells(np.array([mx]), np.array([my]))
    v.update()
    assert v.grid.cost_at(0.3, 0.0) == FREE_SPACE
    v.add_observation("kinect", (0.0, 0.0, 0.54), pts, stamp=1.0)
    v.update()
    v.reset()
    v.buffers["kinect"].observations.clear()
    v.update()
    assert int(v.bits.sum()) == 0


def test_voxel_centres_for_rviz():
    v = layer()
    v.add_observation("kinect", KINECT, np.array([[1.02, 0.02, 0.71]]), stamp=0.0)
    v.update()
    centres = v.voxel_centres()
    assert centres.shape == (1, 3)
    assert centres[0] == pytest.approx([1.025, 0.025, 0.725])


def test_layered_costmap_with_voxels_inflates_the_table_top_and_frees_the_footprint():
    fp = np.array([[-0.17, -0.17], [-0.17, 0.17], [0.2, 0.17], [0.25, 0.0], [0.2, -0.17]])
    lay = LayeredCostmap(80, 80, 0.05, -2.0, -2.0, footprint=fp, rolling_window=True, static_map=False,
                         sources=[ObservationSource("kinect", min_obstacle_height=0.05, max_obstacle_height=1.0,
                                                    clearing=True)],
                         inflation_radius=0.4, voxel={"z_resolution": 0.05, "z_voxels": 20})
    lay.obstacles.add_observation("kinect", KINECT, table_top(0.7, 1.5, -0.4, 0.4), stamp=0.0)
    lay.update(0.0, 0.0, 0.0)
    assert lay.costmap.cost_at(0.75, 0.0) == LETHAL_OBSTACLE
    assert lay.costmap.cost_at(0.6, 0.0) == 253  # within the inscribed radius of the top's edge
    # the robot drives on to 0.3 m from the top's edge; nothing sees the top any more
    lay.obstacles.add_observation("kinect", KINECT, np.zeros((0, 3)), stamp=1.0)
    lay.update(0.4, 0.0, 0.0)
    assert lay.costmap.cost_at(0.72, 0.0) == LETHAL_OBSTACLE
    assert lay.footprint_cost(0.4, 0.0, 0.0) >= 0.0
    assert lay.footprint_cost(0.5, 0.0, 0.0) == -1.0  # 5 cm on, the robot's nose would be under it
