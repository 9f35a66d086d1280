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
import time
from dataclasses import dataclass

import numpy as np
import rospy

from florence_common import pose as pose2d
from florence_common.people import acquire
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

    def attend(self, goal_xy, base_frame, radius, max_age, wait=0.5, **kwargs):
        """The tracked person nearest to ``goal_xy`` (x, y) in ``base_frame`` within ``radius`` [m]:
        (florence_common.people.AttendedPerson, Snapshot, robot pose in the tracker's frame, None), or
        (None, None, None, why not). The tracker's next messages are waited for up to ``wait`` [s of
        wall time] when the latest has nobody there (a track that flickered). ``kwargs`` go to the
        AttendedPerson."""
        deadline = time.monotonic() + wait
        while True:
            snap = self.latest(max_age=max_age)
            if snap is None:
                why = self.problem
            else:
                robot, why = self.robot_pose(snap.frame or "odom", base_frame)
                if robot is not None:
                    point = pose2d.transform_points(robot, [goal_xy])[0]
                    person, why = acquire(snap.ids, snap.xy, snap.velocities, snap.stamp, point, radius, **kwargs)
                    if person is not None:
                        return person, snap, robot, None
                    why = f"{why} (goal ({goal_xy[0]:.2f}, {goal_xy[1]:.2f}) in {base_frame})"
            if time.monotonic() >= deadline or rospy.is_shutdown():
                return None, None, None, why
            time.sleep(0.05)

    def robot_pose(self, frame, base_frame):
        """((x, y, yaw) of ``base_frame`` in ``frame``, latest), or (None, why)."""
        m, why = lookup_matrix(self.tf_buffer, frame, base_frame, rospy.Time(0))
        if m is None:
            return None, why
        return pose2d.from_matrix(m), None

    def unregister(self):
        self.sub.unregister()
