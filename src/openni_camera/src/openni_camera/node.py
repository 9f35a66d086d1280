"""openni_camera_node: the Kinect's depth and colour cameras over libfreenect (seed 2.2.1, Table 3).

libfreenect runs in a worker process (openni_camera.worker) that streams 11-bit depth and RGB
at 640x480 / 30 Hz; this node converts and publishes with openni_camera's conventions. Streams
are lazy: a topic nobody subscribes to costs nothing but its camera_info.

ROS Parameters: PARAMS below (rendered in the README); ~diagnostic_period (float, 1.0, s) is
read by diagnostic_updater.

ROS Publishers (relative names: the launch files start the node in namespace camera):
    depth/image (sensor_msgs/Image, 32FC1 [m], NaN for no return): with ~depth_registration
        registered to the colour camera (its grid and frame), else on the depth camera's grid.
    depth/camera_info (sensor_msgs/CameraInfo): the intrinsics of depth/image.
    rgb/image_color (sensor_msgs/Image, rgb8), rgb/camera_info (sensor_msgs/CameraInfo).
    rgb/points (sensor_msgs/PointCloud2: x, y, z FLOAT32 [m], rgb FLOAT32 holding 0x00RRGGBB;
        organised 640x480 as the colour image, NaN where no depth; in the colour camera's frame):
        depth registered to colour, each point coloured by its own pixel.
    /diagnostics: connection (or why there is none), stream rates, conversion time, calibration.
"""

import math
import threading
import time
from collections import deque

import numpy as np
import rospy
from sensor_msgs.msg import CameraInfo as CameraInfoMsg
from sensor_msgs.msg import Image, PointCloud2

from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.diagnostics import ERROR, OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from florence_common_ros.throttle import KindThrottle
from openni_camera import camera_info, freenect, kinect, worker
from openni_camera.device import KinectLink
from openni_camera.link_log import LinkLog
from openni_camera.messages import camera_info_msg, cloud_msg, image_msg
from openni_camera.registration import Registration

NAME = "openni_camera"


def _three_finite(value):
    if len(value) != 3 or not all(isinstance(v, int | float) and math.isfinite(v) for v in value):
        return "expected [x, y, z], three finite numbers [m]"
    return None


PARAMS = ParamTable(
    Param("device_id", str, "#1", 'which Kinect: "#N" for the N-th one libfreenect finds, or its camera serial'),
    Param("library", str, freenect.DEFAULT_LIBRARY, "libfreenect to load: a name the dynamic loader finds "
          "(LD_LIBRARY_PATH) or a path; fakenect's (/usr/lib/x86_64-linux-gnu/fakenect/libfreenect.so.0.5) replays the "
          "dump FAKENECT_PATH names"),
    Param("depth_registration", bool, True, "publish depth/image registered to the colour camera (its grid, "
          "camera_info and frame), as openni_camera did with registration on; false: the depth camera's own"),
    Param("depth_rate", float, kinect.RATE, "most depth images and clouds published a second (frames beyond are "
          "skipped)", unit="Hz", gt=0, le=kinect.RATE),
    Param("rgb_rate", float, kinect.RATE, "most colour images published a second", unit="Hz", gt=0, le=kinect.RATE),
    Param("depth_frame_id", FRAME, "camera_depth_optical_frame", "optical frame of the depth camera"),
    Param("rgb_frame_id", FRAME, "camera_rgb_optical_frame", "optical frame of the colour camera"),
    Param("depth_camera_info_url", str, "", "calibration of the depth camera (file:///path.yaml or "
          "package://pkg/path.yaml, camera_calibration format); empty: the Kinect's defaults (f 575.8 px, "
          "centre 314.5, 235.5)"),
    Param("rgb_camera_info_url", str, "", "calibration of the colour camera; empty: the Kinect's defaults (f 525 px, "
          "centre 319.5, 239.5)"),
    Param("rgb_offset", list, list(kinect.RGB_IN_DEPTH), "position of the colour camera in the depth camera's "
          "optical frame (no rotation between them), as the robot description places the two frames", unit="m",
          check=_three_finite),
    Param("baseline", float, kinect.BASELINE, "projector baseline b of the depth model z = 8 b f / (doff - raw), "
          "f the depth camera's fx", unit="m", gt=0),
    Param("disparity_offset", float, kinect.DISPARITY_OFFSET, "doff of that model", gt=0, le=kinect.RAW_NO_VALUE),
    Param("depth_time_offset", float, 0.0, "added to the depth stamps (the Kinect's latency is about -0.055 s, as "
          "the TurtleBot's electric launch file set)", unit="s"),
    Param("image_time_offset", float, 0.0, "added to the colour stamps", unit="s"),
    Param("sync_slop", float, 0.05, "a colour frame colours the cloud of a depth frame at most this far apart",
          unit="s", gt=0),
    Param("reconnect_interval", float, 1.0, "wait between attempts to open a lost or missing Kinect", unit="s", gt=0),
    Param("frame_timeout", float, 2.0, "no frame for this long while streaming means the device is lost (it is "
          "reopened)", unit="s", gt=0),
)


class OpenniCameraNode:
    def __init__(self):
        p = read_params(PARAMS)
        self.p = p
        device = p["device_id"].strip()
        if not device or (device.startswith("#") and not (device[1:].isdigit() and int(device[1:]) >= 1)):
            raise ValueError(f'~device_id {device!r}: expected "#N" (N >= 1) or a camera serial')
        self.problems = {}  # diagnostics name -> calibration problems
        self.depth_info = self._calibration("depth", p["depth_camera_info_url"], camera_info.default_depth())
        self.rgb_info = self._calibration("rgb", p["rgb_camera_info_url"], camera_info.default_rgb())
        self.registration = Registration(self.depth_info, self.rgb_info, p["rgb_offset"], baseline=p["baseline"],
                                         disparity_offset=p["disparity_offset"]).warm_up()
        self.depth_gate, self.rgb_gate = kinect.RateGate(p["depth_rate"]), kinect.RateGate(p["rgb_rate"])
        self.lock = threading.Lock()
        self.rgb = None  # (host time [s], (H, W, 3) uint8) of the newest colour frame
        # the cloud's array, filled again every frame: rospy serialises a message within publish()
        self.cloud_buffer = np.empty((self.rgb_info.height, self.rgb_info.width, 4), dtype=np.float32)
        self.waiting = None  # (host time, stamp, raw, registered depth or None) of a depth frame awaiting its colour
        self.conversion_ms = deque(maxlen=300)
        self.counts = {"depth": 0, "rgb": 0, "clouds": 0, "unpaired": 0, "skipped": 0, "errors": 0}
        self.dropped_by_worker = 0
        self.log = LinkLog(NAME, p["reconnect_interval"])
        self.warn = KindThrottle(f"{NAME}: ")

        self.pub_depth = rospy.Publisher("depth/image", Image, queue_size=2)
        self.pub_depth_info = rospy.Publisher("depth/camera_info", CameraInfoMsg, queue_size=2)
        self.pub_rgb = rospy.Publisher("rgb/image_color", Image, queue_size=2)
        self.pub_rgb_info = rospy.Publisher("rgb/camera_info", CameraInfoMsg, queue_size=2)
        self.pub_points = rospy.Publisher("rgb/points", PointCloud2, queue_size=2)
        self.diag = Diagnostics(f"Kinect {device}")
        self.diag.add("Connection", self._diag_connection)
        self.depth_rate = self.diag.frequency("Depth rate", 0.9 * p["depth_rate"], 1.1 * p["depth_rate"])
        self.rgb_rate = self.diag.frequency("Colour rate", 0.9 * p["rgb_rate"], 1.1 * p["rgb_rate"])
        self.diag.add("Processing", self._diag_processing)
        try:
            self.link = KinectLink("camera", p["library"], device, reconnect_interval=p["reconnect_interval"],
                                   frame_timeout=p["frame_timeout"], on_record=self._on_record,
                                   on_event=self._on_event)
        except (OSError, freenect.FreenectError) as exc:
            raise ValueError(f"~library {p['library']!r}: {exc}") from None
        self.link.start()
        rospy.loginfo("%s: depth %s, colour %s, depth registration %s; opening the Kinect through %s", NAME,
                      "calibrated" if p["depth_camera_info_url"] and "depth" not in self.problems else "defaults",
                      "calibrated" if p["rgb_camera_info_url"] and "rgb" not in self.problems else "defaults",
                      "on" if p["depth_registration"] else "off", self.link.library_file)

    def _calibration(self, which, url, default):
        import rospkg

        info, problem = camera_info.load(url, kinect.WIDTH, kinect.HEIGHT, default, camera_name=which,
                                         package_path=rospkg.RosPack().get_path)
        if problem:
            self.problems[which] = problem
            rospy.logerr("%s: %s calibration not used: %s; publishing the Kinect's default intrinsics", NAME, which,
                         problem)
        return info

    # --- the worker's records (its reading thread) -------------------------------------------------------------------
    def _on_event(self, kind, text):
        self.log(self.link, kind, text)

    def _on_record(self, record):
        self.dropped_by_worker = record.dropped
        try:
            if record.kind == worker.DEPTH:
                self._on_depth(record)
            elif record.kind == worker.VIDEO:
                self._on_video(record)
        except Exception as exc:  # noqa: BLE001 - one bad frame must not end the stream
            self.counts["errors"] += 1
            self.warn(f"{record.kind!r} frame", f"frame dropped: {exc!r}")

    def _stamp(self, host_time, offset):
        return rospy.Time.from_sec(rospy.get_time() - (time.monotonic() - host_time) + offset)

    def _on_video(self, record):
        if len(record.payload) != kinect.RGB_BYTES:
            raise ValueError(f"colour frame of {len(record.payload)} bytes, expected {kinect.RGB_BYTES}")
        if not self.rgb_gate.admit(record.host_time):
            self.counts["skipped"] += 1
            return
        rgb = np.frombuffer(record.payload, dtype=np.uint8).reshape(kinect.HEIGHT, kinect.WIDTH, 3)
        with self.lock:
            self.rgb = (record.host_time, rgb)
        self.counts["rgb"] += 1
        self.rgb_rate.tick()
        stamp = self._stamp(record.host_time, self.p["image_time_offset"])
        frame = self.p["rgb_frame_id"]
        if self.pub_rgb.get_num_connections():
            self.pub_rgb.publish(image_msg(rgb, "rgb8", stamp, frame))
        if self.pub_rgb_info.get_num_connections():
            self.pub_rgb_info.publish(camera_info_msg(self.rgb_info, stamp, frame))
        waiting, self.waiting = self.waiting, None
        if waiting is not None:  # a depth frame that came before its colour frame
            host_time, stamp, raw, on_rgb_grid = waiting
            if abs(record.host_time - host_time) <= self.p["sync_slop"]:
                start = time.perf_counter()
                cloud = self.registration.cloud(self.registration.register(raw) if on_rgb_grid is None else
                                                on_rgb_grid, rgb, self.cloud_buffer)
                self.conversion_ms.append(1000.0 * (time.perf_counter() - start))
                self._publish_cloud(cloud, stamp)
            else:
                self.counts["unpaired"] += 1

    def _publish_cloud(self, cloud, stamp):
        if self.pub_points.get_num_connections():
            self.pub_points.publish(cloud_msg(cloud, stamp, self.p["rgb_frame_id"]))
            self.counts["clouds"] += 1

    def _on_depth(self, record):
        if len(record.payload) != kinect.DEPTH_BYTES:
            raise ValueError(f"depth frame of {len(record.payload)} bytes, expected {kinect.DEPTH_BYTES}")
        if not self.depth_gate.admit(record.host_time):
            self.counts["skipped"] += 1
            return
        self.counts["depth"] += 1
        self.depth_rate.tick()
        p = self.p
        raw = np.frombuffer(record.payload, dtype="<u2").reshape(kinect.HEIGHT, kinect.WIDTH)
        want_depth, want_info = self.pub_depth.get_num_connections(), self.pub_depth_info.get_num_connections()
        want_points = self.pub_points.get_num_connections()
        colour, wait = None, False
        if want_points:
            with self.lock:
                rgb = self.rgb
            if rgb is not None and abs(rgb[0] - record.host_time) <= p["sync_slop"]:
                colour = rgb[1]
            elif rgb is None or rgb[0] < record.host_time:
                wait = True  # the colour frame of this instant may be next: the cloud waits for it
            else:
                self.counts["unpaired"] += 1
        registered = p["depth_registration"]
        frame = p["rgb_frame_id"] if registered else p["depth_frame_id"]
        info = self.rgb_info if registered else self.depth_info
        stamp = self._stamp(record.host_time, p["depth_time_offset"])

        start = time.perf_counter()
        on_rgb_grid = self.registration.register(raw) if (colour is not None or (want_depth and registered)) else None
        depth = None
        if want_depth:
            depth = on_rgb_grid if registered else self.registration.metres(raw)
        cloud = self.registration.cloud(on_rgb_grid, colour, self.cloud_buffer) if colour is not None else None
        if on_rgb_grid is not None or depth is not None:
            self.conversion_ms.append(1000.0 * (time.perf_counter() - start))

        if depth is not None:
            self.pub_depth.publish(image_msg(depth, "32FC1", stamp, frame))
        if want_info:
            self.pub_depth_info.publish(camera_info_msg(info, stamp, frame))
        if cloud is not None:
            self._publish_cloud(cloud, stamp)
        if wait:
            if self.waiting is not None:
                self.counts["unpaired"] += 1
            self.waiting = (record.host_time, stamp, raw, on_rgb_grid)

    # --- diagnostics ---------------------------------------------------------------------------------------------
    def _diag_connection(self, stat):
        link = self.link
        if link.connected:
            stat.summary(OK, "streaming" + (" (fakenect replay)" if link.fake else ""))
        else:
            stat.summary(ERROR, link.reason)
        if link.dump_check is not None and link.dump_check.problems:
            stat.mergeSummary(WARN, f"{len(link.dump_check.problems)} records of the dump left out")
        stat.add("Library", link.library_file)
        stat.add("Device", link.info.get("serial") or self.p["device_id"])
        stat.add("Connects", link.connects)
        stat.add("Last reason", link.reason)
        stat.add("Frames dropped before conversion", self.dropped_by_worker)
        if link.fake:
            stat.add("Dump", link.environ.get("FAKENECT_PATH", ""))
            if link.dump_check is not None:
                c = link.dump_check
                stat.add("Dump records (depth, colour, accelerometer)", f"{c.counts['d']}, {c.counts['r']}, "
                         f"{c.counts['a']}")
                stat.add("Dump records left out", len(c.problems))
                if c.problems:
                    stat.add("First left out", c.problems[0])
        if self.log.messages:
            stat.add("Last message", self.log.messages[-1])
        return stat

    def _diag_processing(self, stat):
        times = np.array(self.conversion_ms) if self.conversion_ms else None
        if self.problems:
            stat.summary(WARN, "calibration not used: " + "; ".join(self.problems.values()))
        elif self.counts["errors"]:
            stat.summary(WARN, f"{self.counts['errors']} frames failed")
        else:
            stat.summary(OK, "converting")
        for key, value in self.counts.items():
            stat.add(f"Frames {key}", value)
        if times is not None:
            stat.add("Conversion p50 [ms]", f"{np.percentile(times, 50):.2f}")
            stat.add("Conversion p99 [ms]", f"{np.percentile(times, 99):.2f}")
        stat.add("Depth registration", self.p["depth_registration"])
        stat.add("Depth intrinsics (fx, cx, cy)", f"{self.depth_info.fx:.2f}, {self.depth_info.cx:.2f}, "
                 f"{self.depth_info.cy:.2f}")
        stat.add("Colour intrinsics (fx, cx, cy)", f"{self.rgb_info.fx:.2f}, {self.rgb_info.cx:.2f}, "
                 f"{self.rgb_info.cy:.2f}")
        return stat

    def shutdown(self):
        self.diag.shutdown()
        self.link.stop()


def main():
    run(OpenniCameraNode, "openni_camera_node")
