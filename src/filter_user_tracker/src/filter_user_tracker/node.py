"""filter_user_tracker_node: /tracked_users to /filtered_tracked_users without stale entries
(seed 4.2, Table 15).

ROS Parameters: PARAMS below (rendered in the README).

ROS Subscribers:
    tracked_users (user_tracker_ni/TrackedUsers)

ROS Publishers:
    filtered_tracked_users (user_tracker_ni/TrackedUsers): the same message without the users
        nearer the camera than ~zero_radius and those no sensor saw for ~stale_after; every
        per-user field is filtered alike. A message whose users cannot be placed (no transform
        to the camera) is passed on without the distance rule, with a throttled warning. The camera's
        pose is the latest on tf when that is at most ~transform_tolerance older than the message (the
        Kinect's tilt joint reaches tf at 10 Hz, the tracker publishes at the camera's 15 Hz).
"""

import rospy
import tf2_ros

from filter_user_tracker.stale import keep_mask
from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.node import read_params, run
from florence_common_ros.transforms import lookup_recent_matrix
from user_tracker_ni.msg import TrackedUsers

LOG = "filter_user_tracker: "
PARAMS = ParamTable(
    Param("zero_radius", float, 0.5, "users nearer the camera than this are dropped (the seed's ZERO_RADIUS: "
          "the Kinect sees nothing nearer)", unit="m", ge=0),
    Param("stale_after", float, 0.5, "users no sensor saw for this long are dropped", unit="s", gt=0),
    Param("camera_frame", FRAME, "camera_depth_frame", "the frame distances are measured from"),
    Param("transform_tolerance", float, 0.25, "the camera's latest pose on tf is used when it is at most this much "
          "older than the message (0: only at the message's stamp)", unit="s", ge=0),
)
PER_USER = ("user_ids", "user_ids_ni", "positions", "velocities", "last_seen", "sensors", "facings", "seated")


class FilterUserTrackerNode:
    def __init__(self):
        self.p = read_params(PARAMS)
        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(5.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.pub = rospy.Publisher("filtered_tracked_users", TrackedUsers, queue_size=5)
        rospy.Subscriber("tracked_users", TrackedUsers, self._on_users, queue_size=5)

    def _camera_xy(self, msg):
        if not msg.frame_id:
            rospy.logwarn_throttle(5.0, LOG + "tracked_users without a frame_id: distance rule skipped")
            return None
        m, why, _ = lookup_recent_matrix(self.tf_buffer, msg.frame_id, self.p.camera_frame, msg.stamp,
                                         self.p.transform_tolerance, 0.1)
        if m is None:
            rospy.logwarn_throttle(5.0, LOG + "%s: distance rule skipped", why)
            return None
        return m[:2, 3]

    def _on_users(self, msg):
        n = len(msg.user_ids)
        if any(len(getattr(msg, f)) not in (0, n) for f in PER_USER):
            rospy.logwarn_throttle(5.0, LOG + "message with per-user fields of different lengths passed on as is")
            self.pub.publish(msg)
            return
        if len(msg.positions) != n:  # a tracker of the seed's three fields: nothing to judge by
            self.pub.publish(msg)
            return
        positions = [(p.x, p.y) for p in msg.positions]
        last_seen = [t.to_sec() for t in msg.last_seen] if len(msg.last_seen) == n else [msg.stamp.to_sec()] * n
        camera = self._camera_xy(msg) if n else None
        keep = keep_mask(positions, last_seen, camera, msg.stamp.to_sec(), self.p.zero_radius, self.p.stale_after)
        out = TrackedUsers(stamp=msg.stamp, frame_id=msg.frame_id)
        for field in PER_USER:
            values = getattr(msg, field)
            setattr(out, field, [v for v, k in zip(values, keep, strict=True) if k] if len(values) == n else [])
        out.num_users_tracked = len(out.user_ids)
        self.pub.publish(out)


def main():
    run(FilterUserTrackerNode, "filter_user_tracker_node")
