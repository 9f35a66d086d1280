"""filter_user_tracker_node on a private master: a user near the camera and a stale one are
dropped from every per-user field, the others pass."""

import pytest

from florence_common.processes import rosrun, wait_for

pytestmark = pytest.mark.ros


def test_filter_drops_near_and_stale_users(ros_master, rospy_node, publisher):
    import tf2_ros
    from geometry_msgs.msg import Point, Vector3

    from florence_common_ros.convert import transform_stamped
    from user_tracker_ni.msg import TrackedUsers

    static = tf2_ros.StaticTransformBroadcaster()
    static.sendTransform(transform_stamped(rospy_node.Time.now(), "odom", "camera_depth_frame", 1.0, 0.0, 0.0, z=0.5))
    node = rosrun(ros_master, "filter_user_tracker", "filter_user_tracker_node")
    got = []
    sub = rospy_node.Subscriber("/filtered_tracked_users", TrackedUsers, got.append)
    pub = publisher("/tracked_users", TrackedUsers)
    try:
        wait_for(lambda: pub.get_num_connections() > 0, 30, what="the filter subscribed")
        now = rospy_node.Time.now()
        old = now - rospy_node.Duration(2.0)
        msg = TrackedUsers(user_ids=[1, 2, 3], user_ids_ni=[11, 12, 13], num_users_tracked=3, stamp=now,
                           frame_id="odom",
                           positions=[Point(3.0, 0.0, 0.85), Point(1.2, 0.1, 0.85), Point(2.0, 2.0, 0.85)],
                           velocities=[Vector3(0.1, 0, 0), Vector3(0.2, 0, 0), Vector3(0.3, 0, 0)],
                           last_seen=[now, now, old], sensors=[1, 2, 3], seated=[True, False, False])

        def filtered():
            pub.publish(msg)
            return got and list(got[-1].user_ids) == [1]

        wait_for(filtered, 30, interval=0.2, what="the filtered message")
        out = got[-1]
        assert (list(out.user_ids_ni), out.num_users_tracked, bytes(out.sensors)) == ([11], 1, b"\x01")
        assert out.positions[0].x == 3.0 and out.velocities[0].x == 0.1 and list(out.last_seen) == [now]
        assert list(out.seated) == [True]
    finally:
        sub.unregister()
        node.stop()


def test_a_camera_pose_on_tf_a_moment_behind_the_messages_still_places_the_users(ros_master, rospy_node,
                                                                                    publisher):
    """The Kinect's tilt joint reaches tf at 10 Hz, the tracker publishes at 15 Hz: here the camera's pose is on tf
    only 0.1 s behind each message, never at its stamp. The near user is still dropped (the latest pose, within
    ~transform_tolerance 0.25 s); a lookup at the stamp alone would skip the distance rule and pass them on."""
    import tf2_ros
    from geometry_msgs.msg import Point

    from florence_common_ros.convert import transform_stamped
    from user_tracker_ni.msg import TrackedUsers

    rospy = rospy_node
    tf_pub = tf2_ros.TransformBroadcaster()
    # a camera frame of its own (the first test's static camera_depth_frame stays on /tf_static)
    node = rosrun(ros_master, "filter_user_tracker", "filter_user_tracker_node", "_camera_frame:=tilted_camera")
    got = []
    sub = rospy.Subscriber("/filtered_tracked_users", TrackedUsers, got.append)
    pub = publisher("/tracked_users", TrackedUsers)
    try:
        wait_for(lambda: pub.get_num_connections() > 0, 30, what="the filter subscribed")

        def filtered():
            now = rospy.Time.now()
            tf_pub.sendTransform(transform_stamped(now - rospy.Duration(0.1), "odom", "tilted_camera",
                                                   1.0, 0.0, 0.0, z=0.5))
            pub.publish(TrackedUsers(user_ids=[1, 2], user_ids_ni=[11, 12], num_users_tracked=2, stamp=now,
                                     frame_id="odom", positions=[Point(3.0, 0.0, 0.85), Point(1.2, 0.1, 0.85)],
                                     last_seen=[now, now]))
            return bool(got) and list(got[-1].user_ids) == [1]

        wait_for(filtered, 30, interval=0.2, what="the near user dropped")
    finally:
        sub.unregister()
        node.stop()
