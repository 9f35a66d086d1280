"""The people a user tracker reports, for the behaviours that attend to one of them (follow_me,
approach_me): the latest user_tracker_ni/TrackedUsers as arrays, and the robot's pose in the
tracker's fixed frame.

    people = TrackedPeople("tracked_users", TrackedUsers, tf_buffer, log_prefix="follow_me: ")
    snap = people.latest()            # Snapshot or None; people.problem says why not
    robot, why = people.robot_pose(snap.frame, "base_link")   # (x, y, yaw) in the tracker's frame

The message class is passed in (this package does not depend on the people packages). A message
that cannot be read (no positions, lists of other lengths, no frame) is skipped with a throttled
warning; :attr:`TrackedPeople.problem` keeps the reason for the behaviour's abort text.
"""

import threading
from dataclasses import dataclass

import numpy as np
import rospy

from florence_common import pose as pose2d
from florence_common_ros.convert import tracked_users
from florence_common_ros.transforms import lookup_matrix


@dataclass(frozen=True)
class Snapshot:
    ids: np.ndarray  # [N] persistent ids
    xy: np.ndarray  # [N, 2] [m] in ``frame``
    velocities: np.ndarray  # [N, 2] [m/s]
    frame: str
    stamp: float  # [s] of the tracker's newest reading
    received: float  # [s] ROS time it arrived


class TrackedPeople:
    def __init__(self, topic, msg_class, tf_buffer, log_prefix=""):
        self.tf_buffer = tf_buffer
        self.log_prefix = log_prefix
        self.lock = threading.Lock()
        self._latest = None
        self.received = 0
        self.skipped = 0
        self.problem = f"no message on {rospy.resolve_name(topic)} yet (is user_tracker_ni running?)"
        self.sub = rospy.Subscriber(topic, msg_class, self._on_users, queue_size=1)

    def _on_users(self, msg):
        frame = msg.frame_id.lstrip("/") if hasattr(msg, "frame_id") else ""
        try:
            if not frame and len(msg.user_ids):
                raise ValueError("the message has no frame_id")
            ids, xy, vxy = tracked_users(msg)
        except ValueError as exc:
            with self.lock:
                self.skipped += 1
                self.problem = f"unreadable {self.sub.name} message: {exc}"
            rospy.logwarn_throttle(5.0, self.log_prefix + self.problem)
            return
        snap = Snapshot(ids, xy, vxy, frame, msg.stamp.to_sec(), rospy.get_time())
        with self.lock:
            self._latest = snap
            self.received += 1

    def latest(self, max_age=None):
        """The newest Snapshot, or None (none yet, or older than ``max_age`` [s] of ROS time: then
        :attr:`problem` says so)."""
        with self.lock:
            snap = self._latest
        if snap is None:
            return None
        age = rospy.get_time() - snap.received
        if max_age is not None and age > max_age:
            self.problem = f"no message on {self.sub.name} for {age:.1f} s (is user_tracker_ni running?)"
            return None
        return snap

    def robot_pose(self, frame, base_frame):
        """((x, y, yaw) of ``base_frame`` in ``frame``, latest), or (None, why)."""
        m, why = lookup_matrix(self.tf_buffer, frame, base_frame, rospy.Time(0))
        if m is None:
            return None, why
        return pose2d.from_matrix(m), None

    def unregister(self):
        self.sub.unregister()
