"""kinect_aux_node: the Kinect's tilt motor, LED and accelerometer over libfreenect (seed 2.2.2, Table 4).

libfreenect's motor interface runs in a worker process (openni_camera.worker, the camera
driver's), which reads the motor's state at ~rate and takes the commands.

ROS Parameters: PARAMS below (rendered in the README); ~diagnostic_period (float, 1.0, s) is
read by diagnostic_updater.

ROS Subscribers:
    tilt_angle (std_msgs/Float64, deg): tilt to move to, clamped to -31..31; NaN and infinity ignored.
    led_option (std_msgs/UInt16): LED 0 off, 1 green, 2 red, 3 yellow, 4 and 5 blink green,
        6 blink red/yellow, 7 (undocumented, sent as is); above 7 ignored. Also led_options, the
        seed's Table 4 name.

ROS Publishers:
    imu (sensor_msgs/Imu): linear_acceleration [m/s^2] in ~frame_id (camera_link: x forward,
        y left, z up), covariance 0.01 on the diagonal; no orientation or rates (covariance -1).
    cur_tilt_angle (std_msgs/Float64, deg): the motor's reading (none while it reports no angle).
    cur_tilt_status (std_msgs/UInt8): 0 stopped, 1 at limit, 4 moving (libfreenect's codes).
    kinect_aux/joint_states (sensor_msgs/JointState): ~joint [rad], for robot_state_publisher
        (joint_state_publisher's source, as florence_sim publishes it).
    /diagnostics: connection (or why there is none), state rate, the commands.
"""

import math
import threading

import rospy
from openni_camera.device import KinectLink
from openni_camera.link_log import LinkLog
from sensor_msgs.msg import Imu, JointState
from std_msgs.msg import Float64, UInt8, UInt16

from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.diagnostics import ERROR, OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from florence_common_ros.throttle import KindThrottle
from kinect_aux.motor import decode, led_command, tilt_command
from openni_camera import freenect, worker

NAME = "kinect_aux"
ACCEL_COVARIANCE = 0.01  # [(m/s^2)^2] on the diagonal, as the original kinect_aux

PARAMS = ParamTable(
    Param("device_index", int, 0, "which Kinect: the N-th (from 0) libfreenect finds", ge=0),
    Param("library", str, freenect.DEFAULT_LIBRARY, "libfreenect to load: a name the dynamic loader finds "
          "(LD_LIBRARY_PATH) or a path; fakenect's (/usr/lib/x86_64-linux-gnu/fakenect/libfreenect.so.0.5) replays the "
          "dump FAKENECT_PATH names"),
    Param("rate", float, 10.0, "motor state reads (and publications) a second", unit="Hz", gt=0, le=100),
    Param("frame_id", FRAME, "camera_link", "frame of the accelerometer readings (the Kinect's body)"),
    Param("joint", str, "camera_tilt_joint", "name of the tilt joint in the robot description"),
    Param("reconnect_interval", float, 1.0, "wait between attempts to open a lost or missing motor", unit="s", gt=0),
    Param("frame_timeout", float, 2.0, "no state for this long (at least 3 periods) means the motor is lost",
          unit="s", gt=0),
)


class KinectAuxNode:
    def __init__(self):
        p = read_params(PARAMS)
        self.p = p
        self.lock = threading.Lock()
        self.tilt_target = None  # [deg] the last command sent (sent again after a reconnect)
        self.led = None
        self.counts = {"states": 0, "no angle": 0, "tilt commands": 0, "clamped": 0, "ignored": 0, "failed": 0}
        self.warn = KindThrottle(f"{NAME}: ", period=2.0)
        self.last_state = None
        self.joint_position = None  # [rad]
        self.log = LinkLog(NAME, p["reconnect_interval"])

        self.pub_imu = rospy.Publisher("imu", Imu, queue_size=10)
        self.pub_tilt = rospy.Publisher("cur_tilt_angle", Float64, queue_size=10)
        self.pub_status = rospy.Publisher("cur_tilt_status", UInt8, queue_size=10)
        self.pub_joints = rospy.Publisher("kinect_aux/joint_states", JointState, queue_size=10)
        self.diag = Diagnostics(f"Kinect motor #{p['device_index']}")
        self.diag.add("Motor", self._diag_motor)
        self.state_rate = self.diag.frequency("State rate", 0.8 * p["rate"], 1.2 * p["rate"])
        self.diag.add("Commands", self._diag_commands)
        try:
            self.link = KinectLink("motor", p["library"], f"#{p['device_index'] + 1}", rate=p["rate"],
                                   reconnect_interval=p["reconnect_interval"], frame_timeout=p["frame_timeout"],
                                   on_record=self._on_record, on_event=self._on_event)
        except (OSError, freenect.FreenectError) as exc:
            raise ValueError(f"~library {p['library']!r}: {exc}") from None
        rospy.Subscriber("tilt_angle", Float64, self._on_tilt, queue_size=10)
        rospy.Subscriber("led_option", UInt16, self._on_led, queue_size=10)
        rospy.Subscriber("led_options", UInt16, self._on_led, queue_size=10)
        self.link.start()

    # --- commands ----------------------------------------------------------------------------------------------------
    def _on_tilt(self, msg):
        degrees, note = tilt_command(msg.data)
        if degrees is None:
            self.counts["ignored"] += 1
            self.warn("tilt ignored", note)
            return
        if note:
            self.counts["clamped"] += 1
            self.warn("tilt clamped", note)
        with self.lock:
            self.tilt_target = degrees
        self.counts["tilt commands"] += 1
        self._send(f"tilt {degrees:g}")

    def _on_led(self, msg):
        option, problem = led_command(msg.data)
        if option is None:
            self.counts["ignored"] += 1
            self.warn("led ignored", problem)
            return
        with self.lock:
            self.led = option
        self._send(f"led {option}")

    def _send(self, command):
        if not self.link.send(command):
            self.warn("not connected", f"'{command}' kept for when the motor is back ({self.link.reason})")

    # --- the worker ----------------------------------------------------------------------------------------------
    def _on_event(self, kind, text):
        self.log(self.link, kind, text, what="reading")
        if kind == "connected":
            with self.lock:
                pending = ([f"tilt {self.tilt_target:g}"] if self.tilt_target is not None else []) + \
                          ([f"led {self.led}"] if self.led is not None else [])
            for command in pending:  # what was asked before (or while) the motor was away
                self.link.send(command)

    def _on_record(self, record):
        if record.kind == worker.EVENT:
            self._on_worker_event(record.payload)
            return
        if record.kind != worker.TILT:
            return
        try:
            state = decode(record.payload)
        except Exception as exc:  # noqa: BLE001 - a damaged record is skipped, the stream goes on
            self.warn("state", f"motor state dropped: {exc!r}")
            return
        stamp = rospy.Time.now()
        self.last_state = state
        self.counts["states"] += 1
        self.state_rate.tick()
        imu = Imu()
        imu.header.stamp, imu.header.frame_id = stamp, self.p["frame_id"]
        imu.linear_acceleration.x, imu.linear_acceleration.y, imu.linear_acceleration.z = state.acceleration
        imu.linear_acceleration_covariance = [ACCEL_COVARIANCE, 0, 0, 0, ACCEL_COVARIANCE, 0, 0, 0, ACCEL_COVARIANCE]
        imu.orientation_covariance[0] = -1.0
        imu.angular_velocity_covariance[0] = -1.0
        self.pub_imu.publish(imu)
        self.pub_status.publish(UInt8(max(0, min(255, state.status))))
        if math.isfinite(state.tilt):
            self.pub_tilt.publish(Float64(state.tilt))
            self.joint_position = math.radians(state.tilt)
        else:
            self.counts["no angle"] += 1
        if self.joint_position is not None:
            joints = JointState()
            joints.header.stamp = stamp
            joints.name, joints.position = [self.p["joint"]], [self.joint_position]
            self.pub_joints.publish(joints)

    def _on_worker_event(self, payload):
        import json

        try:
            event = json.loads(payload)
        except ValueError:
            return
        if event.get("event") == "command" and not event.get("ok"):
            self.counts["failed"] += 1
            self.warn("command failed", f"'{event.get('command')}' failed: {event.get('error')}")

    # --- diagnostics ---------------------------------------------------------------------------------------------
    def _diag_motor(self, stat):
        link, state = self.link, self.last_state
        if link.connected:
            stat.summary(OK, "reading" + (" (fakenect replay)" if link.fake else ""))
        else:
            stat.summary(ERROR, link.reason)
        stat.add("Library", link.library_file)
        stat.add("Connects", link.connects)
        stat.add("Last reason", link.reason)
        if link.fake:
            stat.add("Dump", link.environ.get("FAKENECT_PATH", ""))
        if state is not None:
            stat.add("Tilt [deg]", state.tilt)
            stat.add("Tilt status", state.status_text)
            stat.add("Acceleration [m/s^2]", ", ".join(f"{a:.3f}" for a in state.acceleration))
            stat.add("Accelerometer counts", ", ".join(str(c) for c in state.counts))
        return stat

    def _diag_commands(self, stat):
        if self.counts["ignored"] or self.counts["failed"]:
            stat.summary(WARN, self.warn.latest)
        else:
            stat.summary(OK, "no bad commands")
        with self.lock:
            stat.add("Tilt target [deg]", "none" if self.tilt_target is None else f"{self.tilt_target:g}")
            stat.add("LED", "unchanged" if self.led is None else self.led)
        for key, value in self.counts.items():
            stat.add(key.capitalize(), value)
        stat.add("Last problem", self.warn.latest)
        return stat

    def shutdown(self):
        self.diag.shutdown()
        self.link.stop()


def main():
    run(KinectAuxNode, "kinect_aux_node")
