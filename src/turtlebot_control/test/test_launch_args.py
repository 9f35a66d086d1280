"""turtlebot_2dnav_control.launch's arguments as roslaunch resolves them (``roslaunch --nodes`` and
``--dump-params``: nothing is started)."""

import subprocess

import pytest

pytestmark = pytest.mark.ros


def _roslaunch(option, *args):
    out = subprocess.run(["roslaunch", option, "turtlebot_control", "turtlebot_2dnav_control.launch", *args],
                         capture_output=True, text=True, timeout=120, check=True)
    return out.stdout


@pytest.mark.parametrize("args, served", [
    (["sim:=true"], True),  # florence_sim's apartment: its generated keep-out map
    (["sim:=true", "keepout_map_file:=none"], False),  # a map just built in the simulator has none yet
    (["sim:=true", "keepout_map_file:="], True),  # roslaunch drops an empty value: the default stands
    ([], False),  # the robot: none until the user draws one
])
def test_keepout_map_none_turns_it_off(args, served):
    """``keepout_map_file:=none`` serves no keep-out map and leaves both costmaps without one. An empty
    ``keepout_map_file:=`` does not: rosgraph's load_mappings drops it, so bench/slam.py's navigation
    on a freshly saved map got the world's keep-out map shifted onto the saved map's frame, and the
    bedroom's hotspot was refused as "in an obstacle (cost 254)" (issue 22)."""
    nodes = _roslaunch("--nodes", *args)
    params = _roslaunch("--dump-params", *args)
    assert ("/keepout_map_server" in nodes.split()) == served, nodes
    topics = [line.split(":", 1)[1].strip() for line in params.splitlines() if "costmap/keepout_map_topic" in line]
    assert len(topics) == 2 and all((t == "/keepout_map") == served for t in topics), topics
