"""map_server and map_saver as ROS nodes: latched topics, static_map, frame_id, the command-line forms."""

import os
import subprocess
import sys

import numpy as np
import pytest
from map_server.mapfile import load_map
from PIL import Image

from florence_common.processes import ManagedProcess, wait_for

pytestmark = pytest.mark.ros


YAML = ("image: room.png\nresolution: 0.1\norigin: [-2.0, -1.0, 0.3]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")


@pytest.fixture
def map_file(tmp_path):
    pixels = np.full((20, 30), 254, dtype=np.uint8)
    pixels[0, :] = 0  # top row (the map's last row) occupied
    pixels[5:8, 5:8] = 205
    Image.fromarray(pixels).save(tmp_path / "room.png")
    (tmp_path / "room.yaml").write_text(YAML)
    return tmp_path / "room.yaml"


def rosrun(ros_master, *argv, ns_env=None):
    return ManagedProcess(["rosrun", "map_server", *argv], env=ros_master.env(ns_env))


def test_map_server_publishes_and_serves(rospy_node, ros_master, map_file, tmp_path):
    import rospy
    from nav_msgs.msg import MapMetaData, OccupancyGrid
    from nav_msgs.srv import GetMap

    server = rosrun(ros_master, "map_server", str(map_file), "__name:=ms_test", "_frame_id:=world",
                    "map:=ms_map", "map_metadata:=ms_meta", "static_map:=ms_static")
    try:
        got = {}
        rospy.Subscriber("ms_map", OccupancyGrid, lambda m: got.setdefault("map", m))
        rospy.Subscriber("ms_meta", MapMetaData, lambda m: got.setdefault("meta", m))
        wait_for(lambda: "map" in got and "meta" in got, 30, what="latched map and map_metadata")
        msg = got["map"]
        assert msg.header.frame_id == "world"
        assert (msg.info.width, msg.info.height) == (30, 20)
        assert msg.info.resolution == pytest.approx(0.1)
        assert msg.info.origin.position.x == pytest.approx(-2.0)
        assert msg.info.origin.orientation.z == pytest.approx(np.sin(0.15))
        data = np.array(msg.data, dtype=np.int8).reshape(20, 30)
        np.testing.assert_array_equal(data, load_map(str(map_file)).data)
        assert (data[19] == 100).all() and data[13, 6] == -1 and data[0, 0] == 0
        assert got["meta"].width == 30
        rospy.wait_for_service("ms_static", timeout=10)
        assert list(rospy.ServiceProxy("ms_static", GetMap)().map.data) == list(msg.data)

        # map_saver -f from the topic, then the saved pair loads back to the same grid.
        out = tmp_path / "saved" / "copy"
        out.parent.mkdir()
        saver = rosrun(ros_master, "map_saver", "-f", str(out), "map:=ms_map", "dynamic_map:=none")
        wait_for(lambda: not saver.running(), 60, what="map_saver to exit")
        assert saver.proc.returncode == 0, saver.output()
        np.testing.assert_array_equal(load_map(f"{out}.yaml").data, data)
        assert sorted(os.listdir(out.parent)) == ["copy.pgm", "copy.yaml"]
    finally:
        server.stop()


def test_map_server_bad_yaml_names_the_field(ros_master, tmp_path):
    (tmp_path / "bad.yaml").write_text(YAML.replace("resolution: 0.1\n", ""))
    argv = [sys.executable, "-c", "from map_server.node import main; main()", str(tmp_path / "bad.yaml")]
    result = subprocess.run(argv, env=ros_master.env(), capture_output=True, text=True, timeout=60, check=False)
    assert result.returncode == 1
    assert "missing field 'resolution'" in result.stderr


def test_map_saver_uses_dynamic_map(rospy_node, ros_master, tmp_path):
    import rospy
    from nav_msgs.msg import OccupancyGrid
    from nav_msgs.srv import GetMap, GetMapResponse

    grid = OccupancyGrid()
    grid.info.width, grid.info.height, grid.info.resolution = 3, 2, 0.05
    grid.info.origin.orientation.w = 1.0
    grid.data = [0, 100, -1, 50, 10, 70]
    service = rospy.Service("ms_dynamic_map", GetMap, lambda _req: GetMapResponse(map=grid))
    try:
        saver = rosrun(ros_master, "map_saver", "-f", str(tmp_path / "dyn"), "map:=ms_nothing",
                       "dynamic_map:=ms_dynamic_map")
        wait_for(lambda: not saver.running(), 60, what="map_saver to exit")
        assert saver.proc.returncode == 0, saver.output()
        assert load_map(str(tmp_path / "dyn.yaml")).data.tolist() == [[0, 100, -1], [-1, 0, 100]]
    finally:
        service.shutdown()
