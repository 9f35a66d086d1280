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
