"""openni_camera_node against bad input: a damaged dump and a calibration file that is not one, the device
unplugged mid-stream and plugged back, no device at all (the real libfreenect on a machine without a Kinect),
and configurations it cannot start with. Each gives a clear message; the node keeps running (or exits at start-up
with its reason); nothing half-published."""

import shutil

import pytest

from florence_common.processes import ManagedProcess, wait_for
from florence_harness.kinect_replay import FAKENECT_LIBRARY, Probe, record_dump, start_driver, stop_together
from openni_camera import fakenect_dump

pytestmark = pytest.mark.ros

TIMEOUT = 90.0  # [s] a loaded 2-core machine
ERROR, WARN = 2, 1


@pytest.fixture(scope="module")
def nodes(ros_master, rospy_node, tmp_path_factory):
    from sensor_msgs.msg import CameraInfo, Image, PointCloud2

    root = tmp_path_factory.mktemp("bad")
    dump = record_dump(root / "scene", None, frames=2, repeat=150)
    damaged = root / "damaged"
    shutil.copytree(dump, damaged, symlinks=True)
    first_depth = sorted(n for n in (damaged / fakenect_dump.INDEX).read_text().split() if n.startswith("d-")
                         and not (damaged / n).is_symlink())
    (damaged / first_depth[1]).unlink()  # and every later record linking to it dangles
    bad_yaml = root / "rgb.yaml"
    bad_yaml.write_text("image_width: 640\nimage_height: [480\n")
    unplug = root / "unplug"
    shutil.copytree(dump, unplug, symlinks=True)
    common = [f"_library:={FAKENECT_LIBRARY}", "_reconnect_interval:=0.3"]
    procs = {
        "damaged": start_driver(ros_master, "openni_camera", "openni_camera_node", damaged, "__name:=driver",
                                "__ns:=/damaged", *common, f"_rgb_camera_info_url:=file://{bad_yaml}",
                                "_frame_timeout:=20", name="damaged"),
        "unplug": start_driver(ros_master, "openni_camera", "openni_camera_node", unplug, "__name:=driver",
                               "__ns:=/unplug", *common, "_frame_timeout:=20", name="unplug"),
        "nodevice": start_driver(ros_master, "openni_camera", "openni_camera_node", None, "__name:=driver",
                                 "__ns:=/nodevice", "_reconnect_interval:=0.3", name="nodevice"),
    }
    topics = {}
    for ns in procs:
        topics.update({f"/{ns}/depth/image": Image, f"/{ns}/rgb/camera_info": CameraInfo,
                       f"/{ns}/rgb/points": PointCloud2, f"/{ns}/rgb/image_color": Image})
    probe = Probe(rospy_node, topics, diagnostics_prefix="")
    try:
        yield {"procs": procs, "probe": probe, "unplug": unplug, "damaged": damaged}
    except Exception:
        for p in procs.values():
            print(f"----- {p.name} -----\n{p.output()}")
        raise
    finally:
        probe.close()
        stop_together(procs.values())


def test_a_damaged_dump_plays_what_it_has(nodes):
    """Index entries whose file is missing would end fakenect (exit 1): they are left out, named in the log and
    in /diagnostics, and the rest plays. A calibration file that is no YAML: the defaults, and the reason."""
    probe, proc = nodes["probe"], nodes["procs"]["damaged"]
    probe.wait_for("/damaged/depth/image", 3, TIMEOUT)
    wait_for(lambda: probe.diag("damaged/driver: Connection")[0] == WARN, TIMEOUT, what="the dump warning")
    level, message, values = probe.diag("damaged/driver: Connection")
    assert "left out" in message and int(values["Dump records left out"]) >= 150
    assert "missing" in values["First left out"]
    assert "records left out" in proc.output() and "missing" in proc.output()
    level, message, _ = probe.diag("damaged/driver: Processing")
    assert level == WARN and "calibration not used" in message and "not YAML" in message
    info = probe.wait_for("/damaged/rgb/camera_info", 1, TIMEOUT)
    assert list(info.K) == [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0]  # the Kinect's defaults
    cloud = probe.wait_for("/damaged/rgb/points", 1, TIMEOUT)
    assert len(cloud.data) == cloud.row_step * cloud.height == 640 * 480 * 16  # whole clouds only
    assert proc.running()


def test_unplugged_mid_stream_and_back(nodes):
    """The dump's folder taken away while streaming is the device unplugged (fakenect's next record cannot be read
    and it exits): the node says so and keeps trying; back, it streams again."""
    probe, proc, folder = nodes["probe"], nodes["procs"]["unplug"], nodes["unplug"]
    probe.wait_for("/unplug/depth/image", 3, TIMEOUT)
    away = folder.with_name("unplugged")
    folder.rename(away)
    try:
        wait_for(lambda: probe.diag("unplug/driver: Connection")[0] == ERROR, TIMEOUT, what="the loss in diagnostics")
        message = probe.diag("unplug/driver: Connection")[1]
        assert "fakenect" in message, message
        assert proc.running()
    finally:
        away.rename(folder)
    wait_for(lambda: int(probe.diag("unplug/driver: Connection")[2].get("Connects", 0)) >= 2, TIMEOUT,
             what="the reconnect")
    probe.wait_for("/unplug/depth/image", 3, TIMEOUT)
    assert probe.diag("unplug/driver: Connection")[0] == 0
    assert proc.running()


def test_no_device(nodes):
    """The real libfreenect on a machine without a Kinect: an error that says so (with what the USB device list
    tells), the node keeps trying, nothing is published."""
    probe, proc = nodes["probe"], nodes["procs"]["nodevice"]
    wait_for(lambda: probe.diag("nodevice/driver: Connection")[0] == ERROR, TIMEOUT, what="no device in diagnostics")
    message = probe.diag("nodevice/driver: Connection")[1]
    assert "no Kinect" in message, message
    assert "no Kinect" in proc.output() and proc.running()
    assert probe.n("/nodevice/depth/image") == 0 and probe.n("/nodevice/rgb/points") == 0


FATAL = [([f"_library:={FAKENECT_LIBRARY}"], "FAKENECT_PATH"),  # fakenect, but no dump named
         (["_library:=/nonexistent/libfreenect.so"], "~library"),
         (['_device_id:="#0"'], "~device_id"),
         (["_depth_rate:=45"], "~depth_rate")]


def test_cannot_start_says_why(ros_master):
    """Configurations the node cannot work with: exit status 1 at start-up, the reason naming the parameter."""
    import rospkg

    node = f"{rospkg.RosPack().get_path('openni_camera')}/nodes/openni_camera_node"
    environ = ros_master.env()
    environ.pop("FAKENECT_PATH", None)
    procs = [ManagedProcess(["/usr/bin/python3", node, "__name:=driver", f"__ns:=/fatal{k}", *args], env=environ,
                            name=f"fatal{k}") for k, (args, _) in enumerate(FATAL)]
    try:
        wait_for(lambda: not any(p.running() for p in procs), TIMEOUT, what="the nodes to exit")
        for proc, (args, words) in zip(procs, FATAL, strict=True):
            assert proc.proc.returncode == 1, (args, proc.output())
            assert words in proc.output(), (args, proc.output())
    finally:
        stop_together(procs)
