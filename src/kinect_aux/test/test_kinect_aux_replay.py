"""kinect_aux_node on fakenect's libfreenect (LD_LIBRARY_PATH, as the `fakenect` wrapper sets it) replaying a
florence_sim dump with the Kinect tilted down: the accelerometer, the tilt and its status read back as recorded,
the tilt joint's state for robot_state_publisher; commands out of range or not numbers get a clear message."""

import math

import numpy as np
import pytest

from florence_common.processes import wait_for
from florence_harness.kinect_replay import Probe, Truth, record_dump, start_driver
from openni_camera import kinect

pytestmark = pytest.mark.protocol

TILT = -12.5  # [deg] recorded (a half-degree step of the motor's reading)
TIMEOUT = 90.0  # [s] a loaded 2-core machine
WARN = 1


@pytest.fixture(scope="module")
def aux(ros_master, rospy_node, tmp_path_factory):
    from sensor_msgs.msg import Imu, JointState
    from std_msgs.msg import Float64, UInt8

    dump = record_dump(tmp_path_factory.mktemp("aux") / "scene", None, tilt=TILT, frames=2, repeat=300)
    proc = start_driver(ros_master, "kinect_aux", "kinect_aux_node", dump, "__name:=kinect_aux_node",
                        "__ns:=/aux", "_rate:=20", "_frame_timeout:=20",
                        env={"LD_LIBRARY_PATH": "/usr/lib/x86_64-linux-gnu/fakenect"})
    probe = Probe(rospy_node, {"/aux/imu": Imu, "/aux/cur_tilt_angle": Float64, "/aux/cur_tilt_status": UInt8,
                               "/aux/kinect_aux/joint_states": JointState},
                  diagnostics_prefix="aux/kinect_aux_node: ")
    try:
        wait_for(lambda: probe.n("/aux/imu") >= 3, TIMEOUT, what="imu from the replay")
        yield {"truth": Truth(dump), "probe": probe, "proc": proc}
    except Exception:
        print(proc.output())
        raise
    finally:
        probe.close()
        proc.stop()


def test_readback_matches_the_recording(aux):
    probe, truth = aux["probe"], aux["truth"]
    recorded = truth.frames["accel"][0]  # [m/s^2] in camera_link, as simulated
    imu = probe.wait_for("/aux/imu")
    assert imu.header.frame_id == "camera_link"
    got = np.array([imu.linear_acceleration.x, imu.linear_acceleration.y, imu.linear_acceleration.z])
    assert got == pytest.approx(recorded, abs=kinect.GRAVITY / kinect.COUNTS_PER_G)  # within a count
    assert got[0] < -1.0  # tilted down: gravity's reaction leans toward -x of camera_link
    assert imu.orientation_covariance[0] == -1 and imu.linear_acceleration_covariance[0] == 0.01
    assert probe.wait_for("/aux/cur_tilt_angle").data == TILT
    assert probe.wait_for("/aux/cur_tilt_status").data == 0  # stopped
    joints = probe.wait_for("/aux/kinect_aux/joint_states")
    assert list(joints.name) == ["camera_tilt_joint"]
    assert joints.position[0] == pytest.approx(math.radians(TILT))
    assert truth.frames["tilt"][0] == pytest.approx(math.radians(TILT))


def test_commands_out_of_range_are_clamped_or_refused(aux, publisher):
    from std_msgs.msg import Float64, UInt16

    probe = aux["probe"]
    tilt, led = publisher("/aux/tilt_angle", Float64), publisher("/aux/led_option", UInt16)
    wait_for(lambda: tilt.get_num_connections() and led.get_num_connections(), TIMEOUT, what="kinect_aux subscribed")

    def commands():
        return probe.diag("Commands")

    tilt.publish(Float64(45.0))
    wait_for(lambda: commands()[2].get("Tilt target [deg]") == "31", TIMEOUT, what="the clamped tilt target")
    assert int(commands()[2]["Clamped"]) == 1
    tilt.publish(Float64(math.nan))
    wait_for(lambda: int(commands()[2].get("Ignored", 0)) == 1, TIMEOUT, what="NaN ignored")
    assert commands()[2]["Tilt target [deg]"] == "31"  # still the last good command
    led.publish(UInt16(9))
    wait_for(lambda: int(commands()[2].get("Ignored", 0)) == 2, TIMEOUT, what="LED 9 ignored")
    level, message, _ = commands()
    assert level == WARN and "LED option 9 ignored" in message
    led.publish(UInt16(2))
    wait_for(lambda: commands()[2].get("LED") == "2", TIMEOUT, what="LED 2 taken")
    output = aux["proc"].output()
    assert "clamped to 31" in output and "not a number" in output
    assert aux["proc"].running()
    assert probe.wait_for("/aux/imu") is not None  # the readings go on
