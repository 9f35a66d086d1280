"""The navigation parameters that ship: move_base's parameters as the launch file sets them
(the seed's YAML files and the Florence values on top), read through roslaunch's own loader
without starting anything, so an offline measurement uses the values the robot runs with.

    params = move_base_params()
    costmap = CostmapConfig.read(params["global_costmap"].get).layered()
"""

import rospkg

MOVE_BASE_LAUNCH = ("turtlebot_control", "config", "move_base_turtlebot_control.launch")


def launch_file(package, *parts):
    """Path of a file in a ROS package."""
    from pathlib import Path

    return Path(rospkg.RosPack().get_path(package)).joinpath(*parts)


def node_params(launch, node, args=()):
    """The parameters a launch file gives ``node`` (its private namespace, ``/<node>/...``) as a
    nested dict, ``{"global_costmap": {"inflation_radius": 0.4, ...}, "planner_frequency": 1.0, ...}``;
    ``args`` as on roslaunch's command line ("name:=value"). No master needed."""
    import roslaunch.config

    config = roslaunch.config.load_config_default([(str(launch), list(args))], None, verbose=False)
    prefix = f"/{node.strip('/')}/"
    out = {}
    for key, param in config.params.items():
        if not key.startswith(prefix):
            continue
        *path, leaf = key[len(prefix):].split("/")
        branch = out
        for part in path:
            branch = branch.setdefault(part, {})
        branch[leaf] = param.value
    return out


def move_base_params(args=()):
    """move_base's parameters as ``move_base_turtlebot_control.launch`` sets them (:func:`node_params`)."""
    return node_params(launch_file(*MOVE_BASE_LAUNCH), "move_base", args)


class IdealPlanner:
    """The shortest way the robot fits through in the true world, for the bench's ideal times:
    navfn (the launch file's ``NavfnROS`` values) on move_base's global costmap (its
    ``global_costmap`` values) over florence_sim's keep-out map of the world (every obstacle
    below the robot's top, table tops included), with no people and nothing the sensors mark.
    The same for every variant of a run, so their time ratios compare.

    ``grid`` is that map as map_server's GridMap (row 0 at the origin, -1 / 0 / 100), for picking
    goals and drawing tracks."""

    def __init__(self, world=None, args=()):
        import numpy as np
        from florence_sim.mapgen import laser_height_from_description, rasterize
        from florence_sim.robot_model import RobotModel
        from florence_sim.world import load_world
        from map_server.mapfile import GridMap, image_to_occupancy
        from move_base.costmap_config import CostmapConfig
        from move_base.navfn import NavfnPlanner

        from florence_common.maps import map_file

        world = load_world(str(world or map_file("apartment", "apartment.world.yaml")))
        image = rasterize(world, laser_height_from_description(), top=RobotModel.from_xacro().height())
        data = image_to_occupancy(image, False)
        (x0, y0), _ = world.bounds
        self.grid = GridMap(data=data, resolution=world.resolution, origin=(x0, y0, 0.0))
        params = move_base_params(args)
        self.layered = CostmapConfig.read(params["global_costmap"].get).layered()
        height, width = data.shape
        self.layered.set_static_map(np.asarray(data).ravel(), width, height, world.resolution, x0, y0)
        self.layered.update(x0, y0)
        self.planner = NavfnPlanner(**params.get("NavfnROS", {}))

    def plan(self, start, goal):
        """(N, 2) path [m] from ``start`` to ``goal`` (x, y, yaw), or None when there is none."""
        import numpy as np

        result = self.planner.make_plan(self.layered.costmap, start, goal, 0.0)
        return np.asarray(result.poses)[:, :2] if result.ok else None
