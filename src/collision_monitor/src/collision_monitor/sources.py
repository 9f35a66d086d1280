"""Range sensors as obstacle points in a fixed frame, over ROS: per source of the monitor's ~sources
(approach_me uses the same to check that a pose is free) one subscriber and one memory: a
sensor_msgs/LaserScan into obstacles.ObstacleMemory (``type: scan``), or a depth image
(sensor_msgs/Image 32FC1 [m] or 16UC1 [mm], with its sensor_msgs/CameraInfo) into
depth_memory.DepthMemory (``type: depth``).

A scan or an image is placed through tf (fixed frame <- its frame, at its stamp): the inverted
Hokuyo's frame is rolled by pi, and tf turns its points right; the depth image's optical frame
carries the Kinect's height and tilt. One that cannot be used (no frame, no transform, no beams, a
zero angle increment; no camera_info yet, one of another size or without intrinsics, an encoding
that does not decode) is skipped with a warning throttled per source that says why; the source then
goes stale after its timeout.
"""

import math
import threading
import time
from collections import Counter, deque

import numpy as np
import rospy
from sensor_msgs.msg import CameraInfo, Image, LaserScan

from collision_monitor.depth_memory import DepthFrame
from collision_monitor.obstacles import DEPTH, SCAN, Scan, camera_info_topic, make_memory
from florence_common.camera import Camera
from florence_common_ros.convert import depth_image_metres
from florence_common_ros.throttle import KindThrottle
from florence_common_ros.transforms import lookup_matrix

FORGET_SETTLE = 0.25  # [s] readings stamped up to this long after forget() are not used either (forget)


class _Unusable(ValueError):
    """A scan or an image that cannot be used: ``kind`` of problem (warnings are throttled per kind)
    and the reason."""

    def __init__(self, kind, why):
        super().__init__(why)
        self.kind = kind


class ScanSources:
    """``specs``: the parsed ~sources entries (obstacles.parse_sources); ``on_scan(name)`` is called
    after each scan or depth image taken (in the subscriber's thread); ``depth_period`` [s]: the
    least time between depth images taken, by their stamps (0: every one, as the monitor needs;
    approach_me, which checks a pose when a goal comes, takes fewer). ``subscribe``: at once (the
    monitor), or False: only between :meth:`resume` and :meth:`pause` (follow_me and approach_me,
    which need what the sensors see only during a goal: subscribed all the time, the depth images
    and scans they skipped or kept for nothing cost each of them 0.025 of a core in florence_sim)."""

    def __init__(self, specs, fixed_frame, tf_buffer, tf_timeout=0.5, on_scan=None, log_prefix="", depth_period=0.0,
                 subscribe=True):
        self.specs = {s.name: s for s in specs}
        self.fixed_frame = fixed_frame
        self.tf_buffer = tf_buffer
        self.tf_timeout = tf_timeout
        self.on_scan = on_scan
        self.log_prefix = log_prefix
        self.depth_period = float(depth_period)
        self.warn = KindThrottle(log_prefix)  # per source and problem: one does not silence another
        self.lock = threading.Lock()
        self.memories = {s.name: make_memory(s) for s in specs}
        self.taken_at = {s.name: -math.inf for s in specs}  # [s] ROS time of the last scan taken
        self.forgotten_at = -math.inf  # [s] ROS time of the last forget(): readings taken before it are not used
        self.taken = Counter()
        self.skipped = Counter()
        self.problem = {s.name: "" for s in specs}  # the last reason a scan was skipped
        self.update_ms = {s.name: deque(maxlen=300) for s in specs}  # [ms] wall time to take each one
        self.camera_info = {}  # depth sources: name -> the latest sensor_msgs/CameraInfo
        self.subs = []
        self._subscribing = threading.Lock()  # resume and pause (a goal's thread and a cancel's)
        if subscribe:
            self.resume()

    def resume(self):
        """Subscribe to every source (if not subscribed), each memory empty: what it held was seen
        before a pause, from a robot that has moved since."""
        with self._subscribing:
            if not self.subs:
                self._subscribe()

    def _subscribe(self):
        with self.lock:
            for memory in self.memories.values():
                memory.clear()
            self.taken_at = dict.fromkeys(self.specs, -math.inf)
        for s in self.specs.values():
            if s.type == DEPTH:
                self.subs += [rospy.Subscriber(camera_info_topic(s), CameraInfo, self._on_camera_info,
                                               callback_args=s.name, queue_size=1),
                              rospy.Subscriber(s.topic, Image, self._on_depth, callback_args=s.name, queue_size=1,
                                               buff_size=2 ** 24)]
            else:
                self.subs.append(rospy.Subscriber(s.topic, LaserScan, self._on_scan, callback_args=s.name,
                                                  queue_size=1))

    def pause(self):
        """Unsubscribe from every source until :meth:`resume` (what the memories hold is kept)."""
        with self._subscribing:
            subs, self.subs = self.subs, []
            for sub in subs:
                sub.unregister()

    def wait_all(self, timeout):
        """Wait up to ``timeout`` [s of wall time] until every source has been taken once since it
        was (re)subscribed; the names of those that were not (a sensor this robot lacks, or silent)."""
        deadline = time.monotonic() + timeout
        while True:
            with self.lock:
                missing = [name for name, t in self.taken_at.items() if not math.isfinite(t)]
            if not missing or time.monotonic() >= deadline or rospy.is_shutdown():
                return missing
            time.sleep(0.01)

    def _skip(self, name, kind, why):
        """Count a skipped scan or image of source ``name``; warn, throttled per source and ``kind`` of
        problem (a new problem is told at once)."""
        with self.lock:
            self.skipped[name] += 1
            self.problem[name] = why
        what = "image" if self.specs[name].type == DEPTH else "scan"
        self.warn((name, kind), f"{name} {what} skipped: {why}")

    def _taken(self, name, start):
        """Count a scan or image of ``name`` taken, its update begun at ``start`` (perf_counter) [s]."""
        with self.lock:
            self.update_ms[name].append(1e3 * (time.perf_counter() - start))
            self.taken[name] += 1
            self.taken_at[name] = rospy.get_time()
        if self.on_scan is not None:
            self.on_scan(name)

    def _before_forget(self, msg):
        """Whether a reading was taken before the last :meth:`forget` (and FORGET_SETTLE after it): it
        shows where the robot was before it was carried (odometry did not move), and would put that
        back around it."""
        return msg.header.stamp.to_sec() < self.forgotten_at

    def _on_scan(self, msg, name):
        if self._before_forget(msg):
            return None
        frame = msg.header.frame_id.lstrip("/")
        if not frame:
            return self._skip(name, "frame", "the scan has no frame_id")
        if not len(msg.ranges) or not (math.isfinite(msg.angle_increment) and msg.angle_increment != 0.0):
            return self._skip(name, "beams", f"{len(msg.ranges)} beams with angle_increment {msg.angle_increment}")
        pose, why = lookup_matrix(self.tf_buffer, self.fixed_frame, frame, msg.header.stamp, self.tf_timeout)
        if pose is None:
            return self._skip(name, "tf", why)
        start = time.perf_counter()
        scan = Scan(np.asarray(msg.ranges, dtype=float), msg.angle_min, msg.angle_increment, msg.range_min,
                    msg.range_max, pose, msg.header.stamp.to_sec())
        with self.lock:
            if self._before_forget(msg):  # forget() came while this scan waited for its transform
                return None
            self.memories[name].update(scan)
        self._taken(name, start)
        return None

    def _on_camera_info(self, msg, name):
        self.camera_info[name] = msg

    def _decode(self, msg, name):
        """(depth [H, W] float32 [m], NaN for no return; its florence_common.camera.Camera) of a depth image;
        _Unusable naming the kind of problem when it cannot be used."""
        if not msg.header.frame_id.lstrip("/"):
            raise _Unusable("frame", "the image has no frame_id")
        info = self.camera_info.get(name)
        if info is None:
            raise _Unusable("camera_info", f"no camera_info on {camera_info_topic(self.specs[name])} yet")
        if (info.width, info.height) != (msg.width, msg.height):
            raise _Unusable("camera_info",
                            f"camera_info is {info.width}x{info.height}, the image {msg.width}x{msg.height}")
        try:
            return depth_image_metres(msg), Camera.from_k(info.K, info.width, info.height)
        except ValueError as exc:
            raise _Unusable("decode", str(exc)) from None

    def _on_depth(self, msg, name):
        if 0.0 <= msg.header.stamp.to_sec() - self.memories[name].stamp < self.depth_period or self._before_forget(msg):
            return None  # not wanted yet (and not a problem; time going back is taken), or taken before a forget
        start = time.perf_counter()
        try:
            depth, camera = self._decode(msg, name)
        except _Unusable as exc:
            return self._skip(name, exc.kind, str(exc))
        decoded = time.perf_counter()
        frame = msg.header.frame_id.lstrip("/")
        pose, why = lookup_matrix(self.tf_buffer, self.fixed_frame, frame, msg.header.stamp, self.tf_timeout)
        if pose is None:
            return self._skip(name, "tf", why)
        start += time.perf_counter() - decoded  # the wait for tf is not work
        # outside the lock (only this subscriber's thread updates this memory; it replaces its
        # points in one assignment): judging a command does not wait for a frame's few ms
        self.memories[name].update(DepthFrame(depth, camera, pose, msg.header.stamp.to_sec()), self._floor_points())
        if self._before_forget(msg):  # forget() came meanwhile: the update kept this image's points
            self.memories[name].clear()
            return None
        self._taken(name, start)
        return None

    def _floor_points(self):
        """The scan sources' points (x, y) [K, 2] in the fixed frame (the laser's, at floor level: what
        holds up what a depth camera keeps blind), or None without a scan source."""
        with self.lock:
            parts = [m.points[:, :2] for name, m in self.memories.items() if self.specs[name].type == SCAN]
        return np.vstack(parts) if parts else None

    def points(self):
        """(every source's obstacle points [N, 3] in the fixed frame, each point's padding [N] [m])."""
        with self.lock:  # a depth memory's points in the plane: one per column
            parts = [(m.columns if self.specs[name].type == DEPTH else m.points, self.specs[name].padding)
                     for name, m in self.memories.items()]
        if not parts:
            return np.zeros((0, 3)), np.zeros(0)
        return (np.vstack([p for p, _ in parts]),
                np.concatenate([np.full(len(p), pad) for p, pad in parts]))

    def forget(self):
        """Drop every remembered point (the robot was carried: odometry did not move, the world did);
        each source's next scan or image taken from now on fills its memory again. One taken before,
        still on its way (a depth image in flight during the carry), is not used: it put the person
        approached last back in front of the robot, below the Kinect's view as it came on, for good
        (bench/enablers.py: 2 approach placements of 20 stopped 0.4 m on, "no progress for 5 s"). Nor
        is one whose use began before the call and ended after it (a depth image waiting for its
        transform), nor one stamped up to FORGET_SETTLE after the call: this node's clock may be behind
        the sensor's (florence_sim's /clock, read late on a loaded machine). The same placement still
        failed 6 times in 6 after the approach before it: a depth image stamped 0.02-0.05 s before the
        call and used after it in 3 of them, nothing seen in the others."""
        self.forgotten_at = rospy.get_time() + FORGET_SETTLE
        with self.lock:
            for memory in self.memories.values():
                memory.clear()

    def update_times(self, name):
        """[ms] wall time each of the last (up to 300) scans or images of ``name`` took (decoding and
        the memory's update; not the wait for tf)."""
        with self.lock:
            return np.array(self.update_ms[name])

    def ages(self, now):
        """{name: [s] since its last scan was taken (inf: none yet)}."""
        with self.lock:
            return {name: now - t for name, t in self.taken_at.items()}

    def stale(self, now):
        """[(name, age [s], needed)] of the sources silent for longer than their timeout; ``needed``:
        a required source, or an optional one that was heard from (it is part of this robot, and
        failed: the Kinect that stopped sees no table top)."""
        return [(name, age, self.specs[name].required or math.isfinite(age)) for name, age in self.ages(now).items()
                if age > self.specs[name].timeout]

    def unregister(self):
        self.pause()
