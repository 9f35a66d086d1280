"""florence_sim.launch with the shipped apartment and its people: Kinect topics, tilt through
live tf, people, pause/step, test services and fake localization."""

import math
import threading
import time

import numpy as np
import pytest

from florence_harness.processes import roslaunch, wait_for

RTF = 2.0


class Latest:
    def __init__(self, rospy, topic, cls):
        self.msg, self.lock = None, threading.Lock()
        self.sub = rospy.Subscriber(topic, cls, self._cb, queue_size=2)

    def _cb(self, msg):
        with self.lock:
            self.msg = msg

    def get(self):
        with self.lock:
            return self.msg


@pytest.fixture(scope="module")
def apartment(ros_master, rospy_node):
    proc = roslaunch(ros_master, "florence_sim", "florence_sim.launch", f"real_time_factor:={RTF}",
                     "fake_localization:=true", "x:=1.2", "y:=3.0", "yaw:=0.0")
    try:
        yield proc
    finally:
        proc.stop()
        if rospy_node.has_param("/use_sim_time"):
            rospy_node.delete_param("/use_sim_time")  # later tests on this master run on wall time


@pytest.fixture(scope="module")
def topics(apartment, rospy_node):
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import CameraInfo, Image, PointCloud2
    from std_msgs.msg import Float64, UInt8

    from florence_sim.msg import People

    r = rospy_node
    t = {
        "clock": Latest(r, "/clock", Clock),
        "truth": Latest(r, "/base_pose_ground_truth", Odometry),
        "people": Latest(r, "/people_ground_truth", People),
        "depth": Latest(r, "/camera/depth/image", Image),
        "depth_info": Latest(r, "/camera/depth/camera_info", CameraInfo),
        "rgb": Latest(r, "/camera/rgb/image_color", Image),
        "points": Latest(r, "/camera/rgb/points", PointCloud2),
        "tilt": Latest(r, "/cur_tilt_angle", Float64),
        "tilt_status": Latest(r, "/cur_tilt_status", UInt8),
    }
    wait_for(lambda: all(v.get() is not None for v in t.values()) or not apartment.running(), 120.0,
             what="every simulator topic")
    assert apartment.running(), apartment.output()
    yield t
    for v in t.values():
        v.sub.unregister()


def _now(topics):
    return topics["clock"].get().clock.to_sec()


@pytest.mark.ros
def test_kinect_topics_are_honest(topics):
    depth = topics["depth"].get()
    assert (depth.encoding, depth.width, depth.height, depth.step) == ("32FC1", 160, 120, 640)
    assert depth.header.frame_id == "camera_depth_optical_frame"
    values = np.frombuffer(depth.data, dtype="<f4")
    finite = values[np.isfinite(values)]
    assert len(finite) > 0.5 * len(values) and finite.min() >= 0.5 and finite.max() <= 4.2
    info = topics["depth_info"].get()
    assert info.K[0] == pytest.approx(80 / math.tan(math.radians(29)))
    rgb = topics["rgb"].get()
    assert (rgb.encoding, rgb.width, rgb.height, len(rgb.data)) == ("rgb8", 160, 120, 160 * 120 * 3)
    cloud = topics["points"].get()
    assert [f.name for f in cloud.fields] == ["x", "y", "z", "rgb"] and cloud.point_step == 16
    assert cloud.header.frame_id == "camera_rgb_optical_frame" and (cloud.width, cloud.height) == (160, 120)


@pytest.mark.ros
def test_tilt_moves_the_camera_frame_in_tf(topics, rospy_node, tf_buffer):
    import rospy
    from std_msgs.msg import Float64

    pub = rospy.Publisher("/tilt_angle", Float64, queue_size=1, latch=True)
    pub.publish(Float64(20.0))
    wait_for(lambda: abs(topics["tilt"].get().data - 20.0) < 0.1, 60.0, what="cur_tilt_angle at 20 deg")
    assert topics["tilt_status"].get().data in (0, 4)

    def pitch():
        tf = tf_buffer.lookup_transform("kinect_base_link", "camera_link", rospy.Time(0))
        q = tf.transform.rotation
        return math.degrees(math.asin(max(-1.0, min(1.0, 2 * (q.w * q.y - q.z * q.x)))))

    # positive tilt looks up: a negative pitch about camera_link's y axis (REP 103)
    wait_for(lambda: abs(pitch() + 20.0) < 0.5, 60.0, what="camera_link tilted in tf")
    pub.publish(Float64(0.0))
    wait_for(lambda: abs(topics["tilt"].get().data) < 0.1, 60.0, what="tilt back at 0")
    wait_for(lambda: topics["tilt_status"].get().data == 0, 30.0, what="tilt motor stopped")
    pub.unregister()


@pytest.mark.ros
def test_people_walk_their_paths(topics):
    first = {p.id: (p.pose.position.x, p.pose.position.y) for p in topics["people"].get().people}
    assert set(first) == {"alice", "bob"}
    start = _now(topics)
    wait_for(lambda: _now(topics) > start + 4.0, 60.0, what="4 s of sim time")
    later = {p.id: p for p in topics["people"].get().people}
    for pid, (x, y) in first.items():
        p = later[pid]
        assert math.hypot(p.pose.position.x - x, p.pose.position.y - y) > 0.3, f"{pid} walks"
    # bob walks the corridor at y = 6.15 between x = 0.6 and 6.6
    bob = later["bob"].pose.position
    assert bob.y == pytest.approx(6.15, abs=1e-6) and 0.6 - 1e-6 <= bob.x <= 6.6 + 1e-6


@pytest.mark.ros
def test_pause_and_step(topics, rospy_node):
    from std_srvs.srv import Empty

    from florence_sim.srv import Step

    rospy_node.wait_for_service("/florence_sim/pause", 30.0)
    rospy_node.ServiceProxy("/florence_sim/pause", Empty)()
    try:
        t0 = _now(topics)
        wait_for(lambda: _now(topics) == t0, 5.0)  # clock stops
        time.sleep(0.3)
        frozen = _now(topics)
        res = rospy_node.ServiceProxy("/florence_sim/step", Step)(25)
        assert res.sim_time == pytest.approx(frozen + 0.25, abs=1e-6)
        wait_for(lambda: _now(topics) == pytest.approx(res.sim_time), 10.0, what="clock after the steps")
    finally:
        rospy_node.ServiceProxy("/florence_sim/unpause", Empty)()
    wait_for(lambda: _now(topics) > res.sim_time + 0.5, 30.0, what="clock running again")


@pytest.mark.ros
def test_person_services(topics, rospy_node):
    from florence_sim.srv import RemovePerson, SetPerson

    rospy_node.wait_for_service("/florence_sim/set_person", 30.0)
    set_person = rospy_node.ServiceProxy("/florence_sim/set_person", SetPerson)
    res = set_person("carol", "{path: [[4.0, 4.5], [4.0, 6.2]]}")  # through the corridor wall
    assert not res.success and "passes through" in res.message and "corridor_s_2" in res.message
    res = set_person("carol", "{pose: [6.3, 4.0, 1.0], shirt: [0, 1, 0]}")
    assert res.success, res.message
    wait_for(lambda: "carol" in {p.id for p in topics["people"].get().people}, 30.0, what="carol appears")
    res = rospy_node.ServiceProxy("/florence_sim/remove_person", RemovePerson)("carol")
    assert res.success
    wait_for(lambda: "carol" not in {p.id for p in topics["people"].get().people}, 30.0, what="carol gone")
    assert not rospy_node.ServiceProxy("/florence_sim/remove_person", RemovePerson)("nobody").success


@pytest.mark.ros
def test_fake_localization_puts_the_robot_at_ground_truth(topics, tf_buffer):
    import rospy

    def error():
        tf = tf_buffer.lookup_transform("map", "base_footprint", rospy.Time(0))
        truth = topics["truth"].get().pose.pose.position
        return math.hypot(tf.transform.translation.x - truth.x, tf.transform.translation.y - truth.y)

    wait_for(lambda: error() < 0.02, 30.0, what="map->base_footprint = ground truth")
