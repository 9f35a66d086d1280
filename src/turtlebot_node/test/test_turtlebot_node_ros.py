"""turtlebot_node against the Create emulator over a real pseudo-terminal, on a private master."""

import math
import threading
import time
from pathlib import Path

import pytest
from turtlebot_node.create_emulator import CreateEmulator

from florence_common.processes import ManagedProcess, pid_alive, stop_all, wait_for
from florence_common.pty_device import PtyDevice
from turtlebot_node import oi_spec as oi

pytestmark = pytest.mark.protocol


NODE = Path(__file__).resolve().parents[1] / "scripts" / "turtlebot_node.py"
NS = "/tb_test"
GYRO_GAIN = 1.25  # the emulated gyro reads 1/1.25 of the true rate; the driver is told so


class Robot:
    def __init__(self, rospy, link):
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import Imu

        from turtlebot_node.msg import TurtlebotSensorState

        self.rospy = rospy
        self.link = link
        self.emulator = CreateEmulator(gyro_gain=GYRO_GAIN)
        self.device = PtyDevice(self.emulator, link=link).start()
        self.lock = threading.Lock()
        self.latest = {}
        self.states = []
        self.serial_diag = []
        self.cmd_pub = rospy.Publisher(f"{NS}/cmd_vel", Twist, queue_size=5)
        self.subs = [
            rospy.Subscriber(f"{NS}/odom", Odometry, self._keep("odom")),
            rospy.Subscriber(f"{NS}/imu/data", Imu, self._keep("imu")),
            rospy.Subscriber(f"{NS}/turtlebot_node/sensor_state", TurtlebotSensorState, self._on_state),
            rospy.Subscriber("/diagnostics", DiagnosticArray, self._on_diag),
        ]
        self.Twist = Twist

    def _keep(self, key):
        def callback(msg):
            with self.lock:
                self.latest[key] = msg
        return callback

    def _on_state(self, msg):
        with self.lock:
            self.states.append(msg)

    def _on_diag(self, msg):
        for status in msg.status:
            if status.name.endswith("turtlebot_node: Serial link"):
                with self.lock:
                    self.serial_diag.append((status.level, status.message, {v.key: v.value for v in status.values}))

    def drive(self, linear, angular):
        self.cmd_pub.publish(self.Twist(linear=self._vec(linear), angular=self._vec(0.0, angular)))

    @staticmethod
    def _vec(x, z=0.0):
        from geometry_msgs.msg import Vector3
        return Vector3(x, 0.0, z)

    def state_count(self):
        with self.lock:
            return len(self.states)

    def diag(self):
        with self.lock:
            return self.serial_diag[-1] if self.serial_diag else (None, "", {})

    def close(self):
        for sub in self.subs:
            sub.unregister()
        self.cmd_pub.unregister()
        self.device.close()


@pytest.fixture(scope="module")
def robot(ros_master, rospy_node, tmp_path_factory):
    link = str(tmp_path_factory.mktemp("create") / "ttyCreate")
    robot = Robot(rospy_node, link)
    proc = ManagedProcess(["/usr/bin/python3", str(NODE), "__name:=turtlebot_node", f"__ns:={NS}",
                           f"_port:={link}", f"_gyro_scale_correction:={GYRO_GAIN}", "_publish_tf:=true",
                           "_cmd_vel_timeout:=0.5", "_reconnect_interval:=0.2", "_stall_timeout:=0.5"],
                          env=ros_master.env(), name="turtlebot_node")
    robot.proc = proc
    try:
        wait_for(lambda: robot.state_count() > 3, 30.0, what="sensor_state from turtlebot_node")
        wait_for(lambda: robot.cmd_pub.get_num_connections() > 0, 10.0, what="cmd_vel subscriber")
        yield robot
    except Exception:
        print(proc.output())
        raise
    finally:
        stop_all(proc)
        robot.close()


def test_start_up_enters_full_mode_and_streams_group_6(robot):
    snap = robot.emulator.snapshot()
    assert snap["mode"] == oi.MODE_FULL and snap["streaming"]
    commands = snap["commands"]
    assert commands[0] == bytes([128]) and bytes([132]) in commands and bytes([148, 1, 6]) in commands
    with robot.lock:
        states = list(robot.states[-11:])
    assert states[-1].oi_mode == oi.MODE_FULL and states[-1].voltage == 16000
    period = (states[-1].header.stamp - states[0].header.stamp).to_sec() / (len(states) - 1)
    assert period == pytest.approx(0.1, abs=0.03)  # ~sensor_state at 10 Hz


def test_cmd_vel_arrives_as_drive_direct_bytes_and_times_out(robot):
    # 0.2 m/s and 0.4 rad/s on a 258 mm wheel base: right 251.6 -> 252, left 148.4 -> 148 mm/s.
    expected = bytes([145, 0, 252, 0, 148])
    robot.drive(0.2, 0.4)
    sent = time.monotonic()
    wait_for(lambda: expected in robot.emulator.snapshot()["commands"], 5.0, what="drive direct command")
    stop = bytes([145, 0, 0, 0, 0])
    wait_for(lambda: robot.emulator.snapshot()["commands"][-1] == stop, 5.0, what="stop after cmd_vel_timeout")
    assert time.monotonic() - sent >= 0.5
    assert (robot.emulator.right, robot.emulator.left) == (0, 0)


def test_odometry_and_imu_follow_the_emulated_motion(robot, tf_buffer):
    import rospy

    start = time.monotonic()
    rates = []
    while time.monotonic() - start < 2.5:
        robot.drive(0.15, 0.6)
        with robot.lock:
            imu = robot.latest.get("imu")
        if imu is not None and time.monotonic() - start > 0.5:
            rates.append(imu.angular_velocity.z)
        time.sleep(0.1)
    robot.drive(0.0, 0.0)
    wait_for(lambda: robot.emulator.right == robot.emulator.left == 0, 5.0, what="robot stopped")
    truth = robot.emulator.snapshot()

    def settled():
        with robot.lock:
            odom = robot.latest.get("odom")
        return odom if odom and abs(odom.twist.twist.angular.z) < 1e-9 and abs(odom.twist.twist.linear.x) < 1e-9 \
            and odom.header.stamp > rospy.Time.now() - rospy.Duration(0.3) else None

    odom = wait_for(settled, 5.0, what="odometry at rest")
    q = odom.pose.pose.orientation
    yaw = 2.0 * math.atan2(q.z, q.w)
    assert truth["theta"] > 1.0  # it really turned
    assert odom.pose.pose.position.x == pytest.approx(truth["x"], abs=0.01)
    assert odom.pose.pose.position.y == pytest.approx(truth["y"], abs=0.01)
    assert yaw == pytest.approx(truth["theta"], abs=0.01)
    # imu/data: the gyro rate, corrected by gyro_scale_correction, is the true rate of the wheels
    # (227 and 73 mm/s on a 258 mm base), though the emulated gyro reads 1/1.25 of it.
    assert rates and sum(rates) / len(rates) == pytest.approx((227 - 73) / 258, rel=0.01)
    tf = tf_buffer.lookup_transform("odom", "base_footprint", rospy.Time(0), rospy.Duration(2.0))
    assert tf.transform.translation.x == pytest.approx(truth["x"], abs=0.02)


def _service(name, srv_type):
    import rospy

    rospy.wait_for_service(name, 10.0)
    return rospy.ServiceProxy(name, srv_type)


def test_mode_and_digital_output_services_change_the_emulator(robot):
    from turtlebot_node.srv import SetDigitalOutputs, SetTurtlebotMode

    set_mode = _service(f"{NS}/turtlebot_node/set_operation_mode", SetTurtlebotMode)
    assert set_mode(oi.MODE_SAFE).valid_mode
    wait_for(lambda: robot.emulator.mode == oi.MODE_SAFE, 5.0, what="safe mode")
    assert not set_mode(9).valid_mode
    assert set_mode(oi.MODE_PASSIVE).valid_mode
    wait_for(lambda: robot.emulator.mode == oi.MODE_PASSIVE, 5.0, what="passive mode")
    assert set_mode(oi.MODE_FULL).valid_mode
    wait_for(lambda: robot.emulator.mode == oi.MODE_FULL, 5.0, what="full mode")

    outputs = _service(f"{NS}/turtlebot_node/set_digital_outputs", SetDigitalOutputs)
    assert outputs(1, 0, 1).done
    wait_for(lambda: robot.emulator.digital_outputs == 0b101, 5.0, what="digital outputs")
    wait_for(lambda: robot.states[-1].user_digital_outputs == 0b101, 5.0, what="outputs in sensor_state")
    assert outputs(0, 0, 0).done


def test_bump_refuses_forward_motion_only(robot):
    robot.emulator.bumps_wheeldrops = oi.BUMP_LEFT
    wait_for(lambda: robot.states[-1].bumps_wheeldrops == oi.BUMP_LEFT, 5.0, what="bump in sensor_state")
    for _ in range(3):
        robot.drive(0.2, 0.0)
        time.sleep(0.1)
    assert (robot.emulator.right, robot.emulator.left) == (0, 0)
    robot.drive(-0.1, 0.0)
    wait_for(lambda: (robot.emulator.right, robot.emulator.left) == (-100, -100), 5.0, what="reversing allowed")
    robot.emulator.bumps_wheeldrops = 0
    robot.drive(0.0, 0.0)


def test_line_noise_is_counted_and_survived(robot):
    before = robot.state_count()
    good = bytearray(robot.emulator._stream_frame())
    bad = bytearray(good)
    bad[20] ^= 0x10
    robot.device.inject(b"\x00\xff\x13\x35garbage" + bytes(bad) + bytes(good[:25]))
    wait_for(lambda: int(robot.diag()[2].get("checksum_errors", 0)) >= 1, 10.0, what="checksum error in diagnostics")
    _, _, values = robot.diag()
    assert int(values["garbage_bytes"]) > 0
    wait_for(lambda: robot.state_count() > before + 5, 10.0, what="sensor_state after the noise")
    # A frame cut off before the line goes quiet: counted as partial, then the OI is set up again.
    with robot.emulator.lock:
        robot.emulator.streaming = False
    robot.device.inject(bytes(good[:30]))
    wait_for(lambda: int(robot.diag()[2].get("partial_frames", 0)) >= 1, 10.0, what="partial frame counted")
    wait_for(lambda: int(robot.diag()[2].get("stalls", 0)) >= 1 and robot.emulator.streaming, 10.0,
             what="stream set up again after the stall")
    assert pid_alive(robot.proc.pid)
    assert values["modem_lines"] == "False"  # the pty refused the RTS wake-up, and that was fine


def test_port_loss_and_return(robot):
    robot.device.close()
    wait_for(lambda: robot.diag()[0] == 2 and "not connected" in robot.diag()[1], 10.0, what="not connected")
    robot.emulator = CreateEmulator(gyro_gain=GYRO_GAIN)
    robot.device = PtyDevice(robot.emulator, link=robot.link).start()
    wait_for(lambda: int(robot.diag()[2].get("connects", 0)) >= 2, 15.0, what="reconnect")
    wait_for(lambda: robot.emulator.mode == oi.MODE_FULL and robot.emulator.streaming, 10.0, what="set up again")
    before = robot.state_count()
    wait_for(lambda: robot.state_count() > before + 3, 10.0, what="sensor_state after the reconnect")
    assert pid_alive(robot.proc.pid)
