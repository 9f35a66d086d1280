"""user_tracker_ni_node on a private master, fed synthetic Kinect frames and scans: a person in
view is published on tracked_users (and tracked_people), as a tf frame and as markers; bad input
(NaN images, a camera_info of another size, millimetre images, colour without depth, a frame with
no transform, NaN/inf scans) is skipped with a reason and tracking goes on; a camera mount on tf a
moment behind the frames still places them; Stop and Start keep their meaning."""

import math

import numpy as np
import pytest

from florence_common.processes import rosrun, wait_for
from florence_harness import kinect_scenes as scenes

pytestmark = pytest.mark.ros

RED = (200, 30, 30)
OPTICAL = "camera_depth_optical_frame"


def _static_frames(rospy_node):
    import tf2_ros
    from geometry_msgs.msg import TransformStamped

    from florence_common_ros.convert import matrix_to_transform_msg, transform_stamped

    camera = TransformStamped()
    camera.header.stamp = rospy_node.Time.now()
    camera.header.frame_id, camera.child_frame_id = "base_footprint", OPTICAL
    camera.transform = matrix_to_transform_msg(scenes.CAMERA_POSE)
    laser = transform_stamped(rospy_node.Time.now(), "base_footprint", "base_laser_link", 0.0, 0.0, 0.0, z=0.15)
    odom = transform_stamped(rospy_node.Time.now(), "odom", "base_footprint", 1.0, 2.0, 0.0)
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    broadcaster.sendTransform([camera, laser, odom])
    return broadcaster


@pytest.fixture(scope="module")
def tracker(ros_master, rospy_node, publisher):
    from sensor_msgs.msg import CameraInfo, Image, LaserScan

    from user_tracker_ni.msg import TrackedUsers

    keep = _static_frames(rospy_node)
    node = rosrun(ros_master, "user_tracker_ni", "user_tracker_ni_node", "_tracker/id_wait:=0.3")
    got = []
    sub = rospy_node.Subscriber("/tracked_users", TrackedUsers, got.append, queue_size=100)
    pubs = {"info": publisher("/camera/depth/camera_info", CameraInfo),
            "depth": publisher("/camera/depth/image", Image),
            "colour": publisher("/camera/rgb/image_color", Image),
            "scan": publisher("/scan", LaserScan)}
    try:
        wait_for(lambda: all(p.get_num_connections() > 0 for p in pubs.values()), 60,
                 what=f"the tracker subscribed\n{node.output()}")
        yield node, pubs, got
    finally:
        sub.unregister()
        node.stop()
        del keep


def _info(width=scenes.WIDTH, height=scenes.HEIGHT):
    from sensor_msgs.msg import CameraInfo

    k = scenes.intrinsics(width, height)
    return CameraInfo(width=width, height=height, K=k, P=[k[0], 0, k[2], 0, 0, k[4], k[5], 0, 0, 0, 1, 0],
                      distortion_model="plumb_bob", D=[0.0] * 5)


def _frame(pubs, depth, rgb, frame_id=OPTICAL, info=None, encoding="32FC1"):
    """Publish one camera_info, colour and depth frame stamped now (colour first)."""
    import rospy
    from sensor_msgs.msg import Image

    from florence_common_ros.convert import array_to_image

    stamp = rospy.Time.now()
    info = info or _info()
    info.header.stamp, info.header.frame_id = stamp, frame_id
    pubs["info"].publish(info)
    if rgb is not None:
        colour = array_to_image(rgb, "rgb8")
        colour.header.stamp, colour.header.frame_id = stamp, frame_id
        pubs["colour"].publish(colour)
    if depth is not None:
        image = array_to_image(depth, encoding) if depth.size else Image(encoding=encoding)
        image.header.stamp, image.header.frame_id = stamp, frame_id
        pubs["depth"].publish(image)


def _scan(pubs, ranges):
    import rospy
    from sensor_msgs.msg import LaserScan

    scan = LaserScan(angle_min=-2.0862, angle_increment=2 * math.pi / 1024, range_min=0.02, range_max=5.6,
                     scan_time=0.1, ranges=list(ranges))
    scan.angle_max = scan.angle_min + scan.angle_increment * (len(ranges) - 1)
    scan.header.stamp, scan.header.frame_id = rospy.Time.now(), "base_laser_link"
    pubs["scan"].publish(scan)


def _feed_until(node, pubs, got, cond, what, depth, rgb, timeout=30.0, **kw):
    """Publish the frame at about 15 Hz until ``cond(last tracked_users)`` holds."""
    import time

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        _frame(pubs, depth, rgb, **kw)
        time.sleep(1 / 15)
        if got and cond(got[-1]):
            return got[-1]
    raise AssertionError(f"{what}: last message {got[-1] if got else None}\n{node.output(3000)}")


def _person_scene():
    return scenes.render(scenes.standing(2.5, 0.3, RED), noise=0.0016)


def test_a_person_in_view_is_published_with_a_frame_and_markers(tracker, rospy_node, tf_buffer):
    from visualization_msgs.msg import MarkerArray

    from user_tracker_ni.msg import TrackedUsers

    node, pubs, got = tracker
    markers, people, detections = [], [], []
    sub = rospy_node.Subscriber("/user_tracker_ni_node/markers", MarkerArray, markers.append)
    people_sub = rospy_node.Subscriber("/tracked_people", TrackedUsers, people.append, queue_size=100)
    detections_sub = rospy_node.Subscriber("/user_tracker_ni_node/detections", MarkerArray, detections.append)
    try:
        depth, rgb = _person_scene()
        msg = _feed_until(node, pubs, got, lambda m: m.num_users_tracked == 1, "one user",
                          depth, rgb)
        assert msg.frame_id == "odom"
        # the person stands 2.5 m ahead and 0.3 m left of the robot, which is at (1, 2) in odom
        assert (msg.positions[0].x, msg.positions[0].y) == pytest.approx((3.5, 2.3), abs=0.1)
        assert len(msg.user_ids_ni) == 1 and msg.sensors[0] & 1
        assert list(msg.seated) == [False]  # she stands
        frame = f"user_{msg.user_ids[0]}"
        wait_for(lambda: tf_buffer.can_transform("odom", frame, rospy_node.Time(0)), 10, what=f"tf {frame}")
        t = tf_buffer.lookup_transform("odom", frame, rospy_node.Time(0)).transform.translation
        assert (t.x, t.y) == pytest.approx((3.5, 2.3), abs=0.1)
        wait_for(lambda: any(m.ns == "users" for a in markers for m in a.markers), 10, what="markers")
        # tracked_people: the same person under her per-appearance id
        wait_for(lambda: any(m.num_users_tracked for m in people), 10, what="tracked_people")
        everyone = [m for m in people if m.num_users_tracked][-1]
        assert list(everyone.user_ids) == list(everyone.user_ids_ni) == list(msg.user_ids_ni)
        assert (everyone.positions[0].x, everyone.positions[0].y) == pytest.approx((3.5, 2.3), abs=0.1)
        # ~detections: the Kinect's detection of her, in the fixed frame, not partly hidden (green)
        _feed_until(node, pubs, got, lambda m: any(m.ns == "kinect_detections" for a in detections for m in a.markers),
                    "a detection marker", depth, rgb)
        seen = [m for a in detections for m in a.markers if m.ns == "kinect_detections"][-1]
        assert seen.header.frame_id == "odom" and seen.color.g > 0.5
        assert (seen.pose.position.x, seen.pose.position.y) == pytest.approx((3.5, 2.3), abs=0.1)
    finally:
        sub.unregister()
        people_sub.unregister()
        detections_sub.unregister()


def test_bad_input_is_skipped_with_a_reason_and_tracking_goes_on(tracker, rospy_node):
    from diagnostic_msgs.msg import DiagnosticArray

    node, pubs, got = tracker
    diags = []
    sub = rospy_node.Subscriber("/diagnostics", DiagnosticArray, diags.append)
    try:
        depth, rgb = _person_scene()
        nan = np.full_like(depth, np.nan)

        def warned(needle, *publish):
            """Publish the bad input until /diagnostics names it (the info and depth topics race:
            each kind is fed on its own until its warning is seen)."""

            def seen():
                for send in publish:
                    send()
                rospy_node.sleep(0.05)
                return needle in " ".join(s.message for a in diags for s in a.status if "user_tracker_ni" in s.name)

            wait_for(seen, 20, what=f"{needle!r} in /diagnostics\n{node.output(3000)}")

        warned("no transform",
               lambda: _frame(pubs, nan, rgb),  # no return anywhere
               lambda: _frame(pubs, None, rgb),  # colour without depth
               lambda: _frame(pubs, depth, rgb, frame_id="nowhere"),  # no transform to the base
               lambda: _frame(pubs, np.zeros((0, 0), np.float32), None),  # empty image
               lambda: _scan(pubs, [float("nan"), float("inf"), -1.0, 0.0] * 170))
        warned("does not match camera_info", lambda: _frame(pubs, depth, rgb, info=_info(80, 60)))
        assert "no transform" in node.output() and "does not match camera_info" in node.output(), \
            "each kind of warning is logged, not only the first (throttled per kind)"
        assert node.running(), node.output()
        # millimetre images track like metre images
        mm = np.nan_to_num(depth * 1000.0, nan=0.0).astype(np.uint16)
        _feed_until(node, pubs, got, lambda m: m.num_users_tracked == 1, "tracked from 16UC1",
                    mm, rgb, encoding="16UC1")
        assert "Traceback" not in node.output(), node.output()
    finally:
        sub.unregister()


def test_a_camera_mount_on_tf_a_moment_behind_its_frames_still_places_them(tracker, rospy_node):
    """The Kinect's tilt joint reaches tf (kinect_aux's joint states through robot_state_publisher)
    more slowly than its frames: here the camera's mount is on tf only 0.1 s behind each frame's
    stamp, never at it. The frames are placed by the latest mount (~mount_tolerance 0.25 s) and
    the person is tracked; looked up at the stamp, every frame would be skipped."""
    import tf2_ros
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import TransformStamped

    from florence_common_ros.convert import matrix_to_transform_msg
    from user_tracker_ni.srv import Start, Stop

    node, pubs, got = tracker
    rospy_node.ServiceProxy("/user_tracker_ni_node/Stop", Stop)()
    rospy_node.ServiceProxy("/user_tracker_ni_node/Start", Start)()
    since = len(got)
    broadcaster = tf2_ros.TransformBroadcaster()
    diags = []
    sub = rospy_node.Subscriber("/diagnostics", DiagnosticArray, diags.append)
    tilted = "camera_tilted_optical_frame"

    def mount():
        m = TransformStamped()
        m.header.stamp = rospy_node.Time.now() - rospy_node.Duration(0.1)
        m.header.frame_id, m.child_frame_id = "base_footprint", tilted
        m.transform = matrix_to_transform_msg(scenes.CAMERA_POSE)
        broadcaster.sendTransform(m)

    try:
        depth, rgb = _person_scene()
        for _ in range(3):
            mount()
            rospy_node.sleep(0.05)

        def tracked(msg):
            mount()
            return len(got) > since and msg.num_users_tracked == 1

        msg = _feed_until(node, pubs, got, tracked, "tracked through the latest mount", depth, rgb, frame_id=tilted)
        assert (msg.positions[0].x, msg.positions[0].y) == pytest.approx((3.5, 2.3), abs=0.1)
        wait_for(lambda: any(v.key == "readings placed by the latest mount" and int(v.value) > 0
                             for a in diags for st in a.status for v in st.values), 10,
                 what="the count in /diagnostics")
    finally:
        sub.unregister()


def test_stop_forgets_and_start_begins_afresh_with_the_persistent_id(tracker, rospy_node):
    from user_tracker_ni.srv import Start, Stop

    node, pubs, got = tracker
    stop = rospy_node.ServiceProxy("/user_tracker_ni_node/Stop", Stop)
    start = rospy_node.ServiceProxy("/user_tracker_ni_node/Start", Start)
    depth, rgb = _person_scene()
    first = _feed_until(node, pubs, got, lambda m: m.num_users_tracked == 1, "tracked", depth, rgb)
    res = stop()
    assert res.success and "forgotten" in res.message
    empty = _feed_until(node, pubs, got, lambda m: True, "a message while stopped", depth, rgb)
    assert empty.num_users_tracked == 0 and list(empty.user_ids) == []
    again = stop()
    assert again.success and "already" in again.message
    assert start().success
    second = _feed_until(node, pubs, got, lambda m: m.num_users_tracked == 1, "tracked again", depth, rgb)
    assert list(second.user_ids) == list(first.user_ids), "the same shirt: the same persistent id"
    assert list(second.user_ids_ni) != list(first.user_ids_ni), "a new per-appearance id after Stop"
    restarted = start()
    assert restarted.success and "was tracking" in restarted.message
