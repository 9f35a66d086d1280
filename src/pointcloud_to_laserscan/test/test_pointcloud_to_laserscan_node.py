"""pointcloud_to_laserscan_node with the real robot description: depth image and point
cloud inputs, heights above the floor through tf, bad input survived."""

import math
import time

import numpy as np
import pytest

from florence_common.processes import ManagedProcess, roslaunch, stop_all, wait_for

pytestmark = pytest.mark.ros


K = [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0]
W, H = 640, 480
BAND = ["_min_height:=0.05", "_max_height:=1.0", "_range_min:=0.45", "_range_max:=4.0"]


def node(ros_master, name, *args):
    return ManagedProcess(["rosrun", "pointcloud_to_laserscan", "pointcloud_to_laserscan_node", f"__name:={name}",
                           *BAND, *args], env=ros_master.env(), name=name)


@pytest.fixture(scope="module")
def robot(ros_master, rospy_node, tf_buffer):
    from sensor_msgs.msg import LaserScan

    procs = [roslaunch(ros_master, "turtlebot_control", "description.launch"),
             node(ros_master, "depth_laser", "_input:=depth", "image:=/t/depth", "camera_info:=/t/camera_info",
                  "scan:=/t/scan_depth"),
             node(ros_master, "cloud_laser", "_input:=cloud", "cloud_in:=/t/points", "scan:=/t/scan_cloud")]
    scans = {"depth": [], "cloud": []}
    subs = [rospy_node.Subscriber(f"/t/scan_{k}", LaserScan, lambda m, k=k: scans[k].append((time.monotonic(), m)))
            for k in scans]
    try:
        tf = wait_for(lambda: tf_buffer.lookup_transform("base_footprint", "camera_depth_frame", rospy_node.Time(0)),
                      60.0, what="robot tf")
        yield scans, tf.transform.translation.z  # camera height above the floor [m]
    finally:
        for s in subs:
            s.unregister()
        stop_all(*procs)


def send_until_scan(rospy, sends, scans, what):
    """Publish each (publisher, msg) of ``sends`` every 0.1 s until the scan of one of them arrives
    (the scan carries its input's stamp, so scans of earlier inputs still in flight do not count)."""
    first = rospy.Time.now()

    def sent_and_answered():
        for pub, msg in sends:
            msg.header.stamp = rospy.Time.now()
            pub.publish(msg)
        return next((s for _, s in list(scans) if s.header.stamp >= first), None)

    return wait_for(sent_and_answered, 30.0, interval=0.1, what=what)


def depth_messages(rospy, z, encoding="32FC1"):
    from sensor_msgs.msg import CameraInfo, Image

    frame = "camera_depth_optical_frame"
    info = CameraInfo(width=W, height=H, K=K)
    info.header.frame_id = frame
    data = z.astype(np.float32) if encoding == "32FC1" else np.round(np.nan_to_num(z) * 1000).astype(np.uint16)
    img = Image(width=data.shape[1], height=data.shape[0], encoding=encoding, step=data.shape[1] * data.itemsize,
                data=data.tobytes())
    img.header.frame_id = frame
    return info, img


def test_depth_image_wall_and_floor(robot, rospy_node):
    from sensor_msgs.msg import CameraInfo, Image

    scans, cam_height = robot
    pubs = {"info": rospy_node.Publisher("/t/camera_info", CameraInfo, queue_size=2),
            "image": rospy_node.Publisher("/t/depth", Image, queue_size=2)}
    try:
        info, wall = depth_messages(rospy_node, np.full((H, W), 2.0))
        send_wall = [(pubs["info"], info), (pubs["image"], wall)]
        scan = send_until_scan(rospy_node, send_wall, scans["depth"], "scan of a wall")
        assert scan.header.frame_id == "camera_depth_frame"
        r = np.array(scan.ranges)
        assert r.size == 360 and r[180] == pytest.approx(2.0, abs=0.01)
        assert r[180 + 40] == pytest.approx(2.0 / math.cos(scan.angle_min + 220.5 * scan.angle_increment), rel=0.01)
        assert np.isinf(r[0]) and np.isinf(r[-1])

        # The floor in millimetres (16UC1): every point is at height ~0 above base_footprint,
        # below min_height 0.05 m: nothing is an obstacle. Heights come from tf, not the camera frame.
        rows = (np.arange(H)[:, None] - K[5]) / K[4]
        with np.errstate(divide="ignore"):
            floor = np.where(rows > 0.05, cam_height / rows, 0.0) * np.ones((1, W))
        info, floor_img = depth_messages(rospy_node, np.where(floor < 3.9, floor, 0.0), "16UC1")
        scan = send_until_scan(rospy_node, [(pubs["info"], info), (pubs["image"], floor_img)], scans["depth"],
                               "scan of the floor")
        assert np.all(np.isinf(scan.ranges))

        # Bad input: an image that does not match camera_info, then the wall again.
        _, small = depth_messages(rospy_node, np.full((10, 10), 1.0))
        t_bad = time.monotonic()
        for _ in range(3):
            pubs["image"].publish(small)
        scan = send_until_scan(rospy_node, send_wall, scans["depth"], "scan after a bad image")
        assert scan.ranges[180] == pytest.approx(2.0, abs=0.01)
        assert all(len(s.ranges) == 360 for t, s in scans["depth"] if t > t_bad)
    finally:
        for p in pubs.values():
            p.unregister()


def test_point_cloud_in_band_and_below(robot, rospy_node):
    from sensor_msgs import point_cloud2
    from sensor_msgs.msg import PointCloud2
    from std_msgs.msg import Header

    scans, cam_height = robot
    pub = rospy_node.Publisher("/t/points", PointCloud2, queue_size=2)
    try:
        points = [(1.5, 0.0, 0.0),  # ahead at camera height: kept
                  (1.0, 0.0, -cam_height + 0.01),  # 1 cm above the floor: dropped
                  (2.0, 1.0, 0.0)]  # 26.6 degrees left
        # tf1-style frame name with a leading "/" (regression: tf2 refused it)
        cloud = point_cloud2.create_cloud_xyz32(Header(frame_id="/camera_depth_frame"), points)
        scan = send_until_scan(rospy_node, [(pub, cloud)], scans["cloud"], "scan of a cloud")
        r = np.array(scan.ranges)
        assert r[180] == pytest.approx(1.5, abs=1e-5)
        left = int((math.atan2(1.0, 2.0) - scan.angle_min) / scan.angle_increment)
        assert r[left] == pytest.approx(math.sqrt(5.0), abs=1e-5)
        assert np.count_nonzero(np.isfinite(r)) == 2
    finally:
        pub.unregister()
