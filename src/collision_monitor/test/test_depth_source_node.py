"""collision_monitor_node with a depth-image source on a private master (the Kinect as the monitor
reads it: sensor_msgs/Image and CameraInfo, tf to its optical frame): a wall in the image slows a
command into it; images it cannot use (no camera_info yet, no transform, an encoding that is no
depth) are skipped with their reason in /diagnostics and the node goes on; 16UC1 millimetres are
taken like 32FC1 metres."""

import math
import threading
import time

import numpy as np
import pytest

from florence_common.processes import rosrun, stop_all, wait_for

pytestmark = pytest.mark.ros

WALL = 0.35  # [m] a wall across the robot's path, this far ahead of base_footprint (0.12 m to stop: slowed)
CAMERA_X, CAMERA_Z = 0.05, 0.5  # [m] the optical frame in base_footprint, level, facing forward
W, H, F = 160, 120, 144.3  # [px] size and focal length (58 degrees wide)


def transforms():
    import rospy
    from geometry_msgs.msg import TransformStamped

    from florence_common_ros.convert import matrix_to_transform_msg, transform_stamped

    odom = transform_stamped(rospy.Time(0), "odom", "base_footprint", 0.0, 0.0, 0.0)
    optical = np.eye(4)
    optical[:3, :3] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]  # z forward, x right, y down
    optical[:3, 3] = CAMERA_X, 0.0, CAMERA_Z
    camera = TransformStamped()
    camera.header.frame_id, camera.child_frame_id = "base_footprint", "test_optical"
    camera.transform = matrix_to_transform_msg(optical)
    return [odom, camera]


def camera_info(stamp):
    from sensor_msgs.msg import CameraInfo

    msg = CameraInfo()
    msg.header.stamp, msg.header.frame_id = stamp, "test_optical"
    msg.width, msg.height = W, H
    msg.K = [F, 0.0, (W - 1) / 2, 0.0, F, (H - 1) / 2, 0.0, 0.0, 1.0]
    return msg


def depth_image(stamp, kind):
    """The wall WALL ahead as a depth image of ``kind``: 32FC1 [m], 16UC1 [mm], rgb8 (no depth), or
    32FC1 in a frame tf does not know."""
    from std_msgs.msg import Header

    from florence_common_ros.convert import array_to_image

    z = np.full((H, W), WALL - CAMERA_X, dtype=np.float32)
    z[:, :10] = np.nan  # no return at the left edge
    frame = "test_nowhere" if kind == "no tf" else "test_optical"
    header = Header(stamp=stamp, frame_id=frame)
    if kind == "16UC1":
        return array_to_image(np.nan_to_num(z * 1000.0).astype(np.uint16), "16UC1", header)
    if kind == "rgb8":
        return array_to_image(np.zeros((H, W, 3), np.uint8), "rgb8", header)
    return array_to_image(z, "32FC1", header)


def empty_scan(stamp):
    """A laser scan that sees nothing (the laser is required: without it every motion stops)."""
    from sensor_msgs.msg import LaserScan

    msg = LaserScan()
    msg.header.stamp, msg.header.frame_id = stamp, "base_footprint"
    msg.angle_min, msg.angle_max, msg.angle_increment = -math.pi / 2, math.pi / 2, math.pi / 180
    msg.range_min, msg.range_max = 0.05, 5.0
    msg.ranges = [math.inf] * 181
    return msg


@pytest.fixture(scope="module")
def monitor(ros_master, rospy_node):
    import rospy
    import tf2_ros
    from geometry_msgs.msg import Twist
    from sensor_msgs.msg import CameraInfo, Image, LaserScan

    from collision_monitor.msg import MonitorState

    if rospy.has_param("/use_sim_time"):
        rospy.delete_param("/use_sim_time")
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    broadcaster.sendTransform(transforms())
    proc = rosrun(ros_master, "collision_monitor", "collision_monitor_node", "__name:=depth_monitor",
                  "cmd_vel_in:=/test_dm/in", "cmd_vel:=/test_dm/out",
                  "_sources:=[{name: laser, topic: /test_dm/scan, timeout: 1.0}, "
                  "{name: kinect, topic: /test_dm/depth/image, type: depth, timeout: 1.0, required: false}]")
    states = []
    subs = [rospy.Subscriber("/depth_monitor/state", MonitorState, states.append)]
    cmd = rospy.Publisher("/test_dm/in", Twist, queue_size=10)
    pubs = {"scan": rospy.Publisher("/test_dm/scan", LaserScan, queue_size=10),
            "image": rospy.Publisher("/test_dm/depth/image", Image, queue_size=2),
            "info": rospy.Publisher("/test_dm/depth/camera_info", CameraInfo, queue_size=2)}
    feed = {"kind": "32FC1", "info": False, "age": 0.0}  # age [s]: the images' stamps that much before now
    done = threading.Event()

    def feeder():
        while not done.is_set():
            now = rospy.Time.now()
            pubs["scan"].publish(empty_scan(now))
            if feed["info"]:
                pubs["info"].publish(camera_info(now))
            pubs["image"].publish(depth_image(now - rospy.Duration.from_sec(feed["age"]), feed["kind"]))
            time.sleep(0.1)

    thread = threading.Thread(target=feeder, daemon=True)
    thread.start()
    try:
        wait_for(lambda: cmd.get_num_connections() and subs[0].get_num_connections()
                 and pubs["image"].get_num_connections() and pubs["info"].get_num_connections(), 30,
                 what="connections to collision_monitor_node")
        yield rospy, cmd, states, feed, proc
    finally:
        done.set()
        thread.join()
        for handle in (*subs, cmd, *pubs.values()):
            handle.unregister()
        stop_all(proc)


def send(cmd, states, v, w):
    """Publish (v, w) until the monitor answers it; returns the state message."""
    from geometry_msgs.msg import Twist

    from florence_harness.topics import publish_until_answered

    msg = Twist()
    msg.linear.x, msg.angular.z = v, w
    return publish_until_answered(cmd, msg, states, what="answer from collision_monitor_node")


def kinect_diagnostics(rospy):
    from diagnostic_msgs.msg import DiagnosticArray

    msg = rospy.wait_for_message("/diagnostics", DiagnosticArray, 10)
    for status in msg.status:
        if "Collision monitor" in status.name and "depth_monitor" in status.name + status.hardware_id:
            return next((v.value for v in status.values if v.key.startswith("source kinect")), "")
    return ""


def test_depth_images_are_skipped_with_a_reason_until_they_can_be_used(monitor):
    rospy, cmd, states, feed, _ = monitor
    # no camera_info yet: the images are skipped, the command passes, the optional Kinect reported
    wait_for(lambda: "no camera_info on /test_dm/depth/camera_info yet" in kinect_diagnostics(rospy), 20,
             what="the missing camera_info in /diagnostics")
    state = send(cmd, states, 0.3, 0.0)
    assert state.state == "clear" and "no scan from kinect (optional)" in state.reason, state
    feed["info"] = True
    wait_for(lambda: send(cmd, states, 0.3, 0.0).state == "slow", 15, what="the wall in the image to slow the robot")
    state = send(cmd, states, 0.3, 0.0)
    assert state.nearest.x == pytest.approx(WALL, abs=0.01) and state.clearance == pytest.approx(WALL - 0.17, abs=0.01)
    assert send(cmd, states, -0.3, 0.0).state == "clear", "backing away passes"


@pytest.mark.parametrize("kind, reason", [("no tf", "no transform test_nowhere -> odom"),
                                          ("rgb8", "unsupported depth encoding 'rgb8'")])
def test_an_image_that_cannot_be_used_is_skipped_and_the_source_goes_stale(monitor, kind, reason):
    rospy, cmd, states, feed, proc = monitor
    feed["info"] = True
    feed["kind"] = kind
    try:
        wait_for(lambda: reason in kinect_diagnostics(rospy), 20, what=f"{reason!r} in /diagnostics")
        # heard from, then nothing usable for its timeout: an optional source that fell silent stops it
        wait_for(lambda: send(cmd, states, 0.2, 0.0).state == "blind", 10, what="the stale Kinect to stop motion")
        assert "kinect silent" in send(cmd, states, 0.2, 0.0).reason
        assert reason in proc.output(), "a warning says why"
    finally:
        feed["kind"] = "32FC1"
    wait_for(lambda: send(cmd, states, 0.3, 0.0).state == "slow", 15, what="the Kinect back")


def test_16uc1_millimetres_are_taken(monitor):
    _, cmd, states, feed, _ = monitor
    feed["info"] = True
    feed["kind"] = "16UC1"
    try:
        time.sleep(1.5)  # longer than the timeout: only 16UC1 images since
        state = send(cmd, states, 0.3, 0.0)
        assert state.state == "slow" and state.nearest.x == pytest.approx(WALL, abs=0.01), state
    finally:
        feed["kind"] = "32FC1"


def test_forget_drops_the_remembered_points(monitor):
    """~forget (the robot was carried): the wall goes, and comes back with the next image."""
    from std_srvs.srv import Trigger

    rospy, cmd, states, feed, _ = monitor
    feed["info"] = True
    wait_for(lambda: send(cmd, states, 0.3, 0.0).state == "slow", 15, what="the wall")
    feed["kind"] = "rgb8"  # no usable image for a while: nothing refills the memory
    try:
        time.sleep(0.3)
        answer = rospy.ServiceProxy("/depth_monitor/forget", Trigger)()
        assert answer.success and "forgot" in answer.message, answer
        state = send(cmd, states, 0.3, 0.0)
        assert state.state in ("clear", "blind") and "stop distance" not in state.reason, state
    finally:
        feed["kind"] = "32FC1"
    wait_for(lambda: send(cmd, states, 0.3, 0.0).state == "slow", 15, what="the wall back")


def test_an_image_taken_before_forget_is_not_used(monitor):
    """An image on its way while the robot was carried shows where it was: after ~forget, images stamped
    before it do not bring the wall back; the first taken after it does."""
    from std_srvs.srv import Trigger

    rospy, cmd, states, feed, _ = monitor
    feed["info"] = True
    feed["age"] = 1.5  # taken 1.5 s before they arrive (the source's timeout is 1 s: by wall time it is not silent)
    try:
        wait_for(lambda: send(cmd, states, 0.3, 0.0).state == "slow", 15, what="the wall")
        assert rospy.ServiceProxy("/depth_monitor/forget", Trigger)().success
        forgot = time.monotonic()
        time.sleep(0.6)  # 6 images since, each stamped before the forget
        state = send(cmd, states, 0.3, 0.0)
        assert time.monotonic() - forgot < 1.4, "too slow to tell"
        assert state.state in ("clear", "blind") and "stop distance" not in state.reason, state
    finally:
        feed["age"] = 0.0
    wait_for(lambda: send(cmd, states, 0.3, 0.0).state == "slow", 15, what="the wall back")
