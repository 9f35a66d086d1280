"""Range sensors as obstacle points in a fixed frame, over ROS: one sensor_msgs/LaserScan
subscriber and one obstacles.ObstacleMemory per source (the monitor's ~sources; approach_me uses
the same to check that a pose is free).

A scan is placed through tf (fixed frame <- the scan's frame, at the scan's stamp): the inverted
Hokuyo's frame is rolled by pi, and tf turns its points right. A scan that cannot be used (no
frame, no transform, no beams, a zero angle increment) is skipped with a throttled warning that
says why; the source then goes stale after its timeout.
"""

import math
import threading
from collections import Counter

import numpy as np
import rospy
from sensor_msgs.msg import LaserScan

from collision_monitor.obstacles import ObstacleMemory, Scan
from florence_common_ros.transforms import lookup_matrix


class ScanSources:
    """``specs``: the parsed ~sources entries (obstacles.parse_sources); ``on_scan(name)`` is called
    after each scan taken (in the subscriber's thread)."""

    def __init__(self, specs, fixed_frame, tf_buffer, tf_timeout=0.5, on_scan=None, log_prefix=""):
        self.specs = {s.name: s for s in specs}
        self.fixed_frame = fixed_frame
        self.tf_buffer = tf_buffer
        self.tf_timeout = tf_timeout
        self.on_scan = on_scan
        self.log_prefix = log_prefix
        self.lock = threading.Lock()
        self.memories = {s.name: ObstacleMemory(s.memory, s.self_range) for s in specs}
        self.taken_at = {s.name: -math.inf for s in specs}  # [s] ROS time of the last scan taken
        self.taken = Counter()
        self.skipped = Counter()
        self.problem = {s.name: "" for s in specs}  # the last reason a scan was skipped
        self.subs = [rospy.Subscriber(s.topic, LaserScan, self._on_scan, callback_args=s.name, queue_size=1)
                     for s in specs]

    def _skip(self, name, why):
        with self.lock:
            self.skipped[name] += 1
            self.problem[name] = why
        rospy.logwarn_throttle(5.0, f"{self.log_prefix}{name} scan skipped: {why}")

    def _on_scan(self, msg, name):
        frame = msg.header.frame_id.lstrip("/")
        if not frame:
            return self._skip(name, "the scan has no frame_id")
        if not len(msg.ranges) or not (math.isfinite(msg.angle_increment) and msg.angle_increment != 0.0):
            return self._skip(name, f"{len(msg.ranges)} beams with angle_increment {msg.angle_increment}")
        pose, why = lookup_matrix(self.tf_buffer, self.fixed_frame, frame, msg.header.stamp, self.tf_timeout)
        if pose is None:
            return self._skip(name, why)
        scan = Scan(np.asarray(msg.ranges, dtype=float), msg.angle_min, msg.angle_increment, msg.range_min,
                    msg.range_max, pose, msg.header.stamp.to_sec())
        with self.lock:
            self.memories[name].update(scan)
            self.taken[name] += 1
            self.taken_at[name] = rospy.get_time()
        if self.on_scan is not None:
            self.on_scan(name)
        return None

    def points(self):
        """(every source's obstacle points [N, 3] in the fixed frame, each point's padding [N] [m])."""
        with self.lock:
            parts = [(m.points, self.specs[name].padding) for name, m in self.memories.items()]
        if not parts:
            return np.zeros((0, 3)), np.zeros(0)
        return (np.vstack([p for p, _ in parts]),
                np.concatenate([np.full(len(p), pad) for p, pad in parts]))

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
        for sub in self.subs:
            sub.unregister()
