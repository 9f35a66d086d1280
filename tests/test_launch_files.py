"""Every launch file of the workspace loads: valid XML, every $(find) and arg resolves,
every rosparam file exists and parses, every node's package exists, and every node's
executable exists, or is on the list of executables that later issues deliver.
"""

import xml.etree.ElementTree as ET

import pytest
import roslaunch.config
import roslaunch.core
import roslaunch.xmlloader
import rospkg
from roslib.packages import find_node

from florence_harness import workspace

pytestmark = pytest.mark.unit

# Executables the seed's launch files start that are not written yet, with the issue
# that delivers them. An entry must be removed once the executable exists (checked below).
PENDING = {
}

FILES = workspace.launch_files()
TOP_LEVEL = [f for f in FILES if f.suffix == ".launch"]
ROOT = workspace.root()


def load(path, argv=()):
    config = roslaunch.config.ROSLaunchConfig()
    loader = roslaunch.xmlloader.XmlLoader()
    loader.ignore_unset_args = False  # roslaunch 1.15 reads it without setting a default
    loader.load(str(path), config, verbose=False, argv=list(argv))
    return config


def test_there_are_launch_files():
    assert len(TOP_LEVEL) >= 10


@pytest.mark.parametrize("path", FILES, ids=[str(f.relative_to(ROOT)) for f in FILES])
def test_launch_file_is_documented_xml(path):
    root = ET.parse(path).getroot()
    assert root.tag == "launch"
    for arg in root.iter("arg"):
        if arg.get("value") is None:
            assert arg.get("doc"), f"<arg name={arg.get('name')!r}> has no doc="


@pytest.mark.parametrize("path", TOP_LEVEL, ids=[str(f.relative_to(ROOT)) for f in TOP_LEVEL])
def test_launch_file_loads_and_nodes_resolve(path):
    config = load(path)
    ros = rospkg.RosPack()
    problems = []
    for node in config.nodes:
        try:
            ros.get_path(node.package)
        except rospkg.ResourceNotFound:
            problems.append(f"node {node.name}: package {node.package!r} not found")
            continue
        if not find_node(node.package, node.type, rospack=ros) and (node.package, node.type) not in PENDING:
            problems.append(f"node {node.name}: no executable {node.type!r} in {node.package}")
    assert not problems, "\n".join(problems)


# Every node of the whole system (SPEC 3, issue 24), by name: what both top-level files start on the
# robot and in simulation, and what only one of the two starts.
SYSTEM_NODES = {
    "/robot_state_publisher", "/joint_state_publisher", "/laser_filter_node", "/laser_combinator_node",
    "/kinect_laser", "/cmd_vel_mux", "/collision_monitor", "/velocity_filter_node", "/map_server", "/amcl",
    "/move_base", "/user_tracker_ni_node", "/filter_user_tracker_node", "/florence_locator", "/detect_users_node",
    "/approach_me_map_node", "/follow_me_node", "/approach_me_node",
}
ROBOT_DRIVERS = {"/turtlebot_node", "/hokuyo_node", "/camera/driver", "/kinect_aux_node"}
SIM_ONLY = {"/florence_sim", "/keepout_map_server"}
SYSTEM_FILES = ["src/florence_bringup/launch/florence_bringup.launch", "src/user_test/launch/florence_user_test.launch"]


@pytest.mark.parametrize("sim", [False, True], ids=["robot", "sim"])
@pytest.mark.parametrize("path", SYSTEM_FILES)
def test_the_whole_system_starts_every_node(path, sim):
    """florence_bringup.launch and florence_user_test.launch: every node of the system once; the robot's
    drivers without sim:=true, florence_sim (and the apartment's keep-out map, on simulated time) with it."""
    config = load(ROOT / path, ["sim:=true"] if sim else [])
    names = [n.namespace.rstrip("/") + "/" + n.name for n in config.nodes]
    assert len(names) == len(set(names)), f"a node started twice: {sorted(names)}"
    expected = SYSTEM_NODES | (SIM_ONLY if sim else ROBOT_DRIVERS)
    assert set(names) == expected, f"missing {expected - set(names)}, unexpected {set(names) - expected}"
    params = {p.key: p.value for p in config.params.values()}
    assert params.get("/use_sim_time", False) is sim
    assert params["/florence_locator/hotspots_file"].endswith("florence_locator/config/hotspots.yaml")


def test_bringup_passes_the_simulation_args_through():
    config = load(ROOT / SYSTEM_FILES[0], ["sim:=true", "x:=6.5", "y:=2.5", "yaw:=3.14", "real_time_factor:=2.5",
                                           "seed:=7", "people:=/tmp/nobody.yaml", "hotspots_file:=/tmp/h.yaml"])
    params = {p.key: p.value for p in config.params.values()}
    assert (params["/florence_sim/x"], params["/florence_sim/y"], params["/florence_sim/yaw"]) == (6.5, 2.5, 3.14)
    assert (params["/amcl/initial_pose_x"], params["/amcl/initial_pose_a"]) == (6.5, 3.14)
    assert params["/florence_sim/real_time_factor"] == 2.5 and params["/florence_sim/seed"] == 7
    assert params["/florence_sim/people_file"] == "/tmp/nobody.yaml"
    assert params["/florence_locator/hotspots_file"] == "/tmp/h.yaml"


def test_every_include_file_is_used():
    included = set()
    for path in TOP_LEVEL:
        included.update(str(p) for p in load(path).roslaunch_files)
    unused = [str(f.relative_to(ROOT)) for f in FILES if f.suffix == ".xml" and str(f) not in included]
    assert not unused, f"include files no launch file uses: {unused}"


def test_pending_executables_are_really_missing():
    """Keeps PENDING honest: once a node is written, its entry must go."""
    ros = rospkg.RosPack()
    written = [f"{pkg}/{exe}" for (pkg, exe) in PENDING if find_node(pkg, exe, rospack=ros)]
    assert not written, f"remove from PENDING, these exist now: {written}"


def test_missing_required_arg_is_reported():
    """The check above would catch a launch file that uses an arg nobody sets."""
    include = ROOT / "src/turtlebot_control/launch/includes/turtlebot_node.launch.xml"
    with pytest.raises(roslaunch.core.RLException, match="port"):
        load(include)


def test_seed_remappings_are_kept():
    config = load(ROOT / "src/turtlebot_control/launch/minimal_control.launch")
    nodes = {n.name: n for n in config.nodes}
    assert ["scan", "scan_combined"] in nodes["laser_filter_node"].remap_args
    assert ["cmd_vel", "filtered_cmd_vel"] in nodes["turtlebot_node"].remap_args
    params = {p.key: p.value for p in config.params.values()}
    assert params["/velocity_filter_node/publishing_rate"] == 50
    assert params["/turtlebot_node/gyro_scale_correction"] == 1.0


def test_move_base_launch_loads_the_seed_yaml_files():
    config = load(ROOT / "src/turtlebot_control/config/move_base_turtlebot_control.launch")
    params = {p.key: p.value for p in config.params.values()}
    assert params["/move_base/global_costmap/inflation_radius"] == 0.40
    assert params["/move_base/local_costmap/inflation_radius"] == 0.40
    assert params["/move_base/local_costmap/rolling_window"] is True
    assert params["/move_base/global_costmap/static_map"] is True
    assert params["/move_base/controller_frequency"] == 5.0
    assert params["/move_base/TrajectoryPlannerROS/vtheta_samples"] == 20
    scan = {k.rsplit("/", 1)[1]: v for k, v in params.items() if k.startswith("/move_base/global_costmap/scan/")}
    assert scan == {"data_type": "LaserScan", "topic": "/filtered_scan", "marking": True, "clearing": True}


@pytest.mark.parametrize(
    "body, error",
    [
        ('<include file="$(find no_such_package_xyz)/launch/x.launch"/>', "no_such_package_xyz"),
        ('<node pkg="rospy" type="x" name="n" args="$(arg never_declared)"/>', "never_declared"),
        ('<rosparam file="$(find turtlebot_control)/config/no_such_file.yaml" command="load"/>', "no_such_file"),
        ("<node pkg='rospy' type='x' name='n'>", ""),  # malformed XML
    ],
    ids=["unresolvable-find", "undeclared-arg", "missing-rosparam-file", "bad-xml"],
)
def test_broken_launch_files_are_caught(tmp_path, body, error):
    """The loader used above fails on each defect the checks are meant to catch."""
    bad = tmp_path / "bad.launch"
    bad.write_text(f"<launch>{body}</launch>")
    with pytest.raises((roslaunch.core.RLException, rospkg.ResourceNotFound), match=error):
        load(bad)
