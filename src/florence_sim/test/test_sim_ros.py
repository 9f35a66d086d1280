"""florence_sim on ROS: florence_sim.launch against a private master, faster than real time.

One launch of a small synthetic world serves the motion, laser-through-tf, bumper and
time tests (TestSmallWorld); a second runs the shipped apartment with its people and
cameras (TestApartment). Each launch lives as long as its test class.
"""

import math
import threading
import time

import numpy as np
import pytest

from florence_common import angles
from florence_common.maps import map_file
from florence_common.processes import roslaunch, wait_for
from florence_common_ros.convert import to_matrix, yaw_of

pytestmark = pytest.mark.scenario

RTF = 3.0  # small world
RTF_APARTMENT = 2.0
WORLD = """
include: [{types}]
map: {{resolution: 0.05, bounds: [[-0.5, -0.5], [6.5, 6.5]]}}
walls:
  - {{type: wall, from: [0, 0], to: [6, 0]}}
  - {{type: wall, from: [6, 0], to: [6, 6]}}
  - {{type: wall, from: [6, 6], to: [0, 6]}}
  - {{type: wall, from: [0, 6], to: [0, 0]}}
rooms:
  room: {{polygon: [[0, 0], [6, 0], [6, 6], [0, 6]], hotspot: [3, 3, 0]}}
"""


class Latest:
    """Keeps the last message of a topic."""

    def __init__(self, rospy, topic, cls):
        self.msg, self.lock = None, threading.Lock()
        self.sub = rospy.Subscriber(topic, cls, self._cb, queue_size=5)

    def _cb(self, msg):
        with self.lock:
            self.msg = msg

    def get(self):
        with self.lock:
            return self.msg


def _launch(ros_master, rospy, tf_buffer, *args):
    """florence_sim.launch with ``args``; stopped (and /use_sim_time cleared) afterwards.

    The session's tf buffer is cleared before and after: every launch restarts simulated time
    at 0, and tf2 would drop the new transforms as older than the cached ones."""
    tf_buffer.clear()
    proc = roslaunch(ros_master, "florence_sim", "florence_sim.launch", *args)
    try:
        yield proc
    finally:
        proc.stop()
        if rospy.has_param("/use_sim_time"):
            rospy.delete_param("/use_sim_time")  # later tests on this master run on wall time
        tf_buffer.clear()


def _subscribe(rospy, proc, spec):
    """``{name: Latest}`` for ``spec`` = {name: (topic, class)}, once every topic has spoken."""
    topics = {name: Latest(rospy, topic, cls) for name, (topic, cls) in spec.items()}
    wait_for(lambda: all(v.get() is not None for v in topics.values()) or not proc.running(), 120.0,
             what="every simulator topic")
    assert proc.running(), proc.output()
    return topics


def _unsubscribe(topics):
    for v in topics.values():
        v.sub.unregister()


@pytest.fixture(scope="class")
def small_world(ros_master, rospy_node, tf_buffer, tmp_path_factory):

    types = map_file("florence_types.yaml")
    world = tmp_path_factory.mktemp("world") / "test.world.yaml"
    world.write_text(WORLD.format(types=types))
    nobody = world.parent / "nobody.yaml"
    nobody.write_text("people: []\n")
    yield from _launch(ros_master, rospy_node, tf_buffer, f"world:={world}", f"people:={nobody}",
                       f"real_time_factor:={RTF}", "x:=3.0", "y:=2.5", "yaw:=0.0")


@pytest.fixture(scope="class")
def topics(small_world, rospy_node):
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import UInt32

    from turtlebot_node.msg import TurtlebotSensorState

    t = _subscribe(rospy_node, small_world, {
        "clock": ("/clock", Clock),
        "odom": ("/odom", Odometry),
        "truth": ("/base_pose_ground_truth", Odometry),
        "scan": ("/scan", LaserScan),
        "state": ("/turtlebot_node/sensor_state", TurtlebotSensorState),
        "collisions": ("/collisions", UInt32),
    })
    yield t
    _unsubscribe(t)


def _set_pose(rospy, x, y, yaw):
    from florence_sim.srv import SetRobotPose

    rospy.wait_for_service("/florence_sim/set_robot_pose", 30.0)
    res = rospy.ServiceProxy("/florence_sim/set_robot_pose", SetRobotPose)(x, y, yaw)
    assert res.success, res.message


def _sim_now(topics):
    return topics["clock"].get().clock.to_sec()


def _drive(publisher, topics, v, w, until, sim_limit):
    """Publish cmd_vel at 50 Hz (wall) until ``until()`` or ``sim_limit`` simulated seconds pass; then stop."""
    from geometry_msgs.msg import Twist

    pub = publisher("/cmd_vel", Twist)
    wait_for(lambda: pub.get_num_connections() > 0, 30.0, what="cmd_vel subscriber")
    start = _sim_now(topics)
    cmd = Twist()
    cmd.linear.x, cmd.angular.z = v, w
    try:
        while not until() and _sim_now(topics) - start < sim_limit:
            pub.publish(cmd)
            time.sleep(0.02)
    finally:
        pub.publish(Twist())
        wait_for(lambda: topics["truth"].get().twist.twist.linear.x == 0.0, 30.0, what="the robot stopped")


def _stepped_drive(rospy, publisher, topics, v, w, until, max_seconds):
    """Drive the paused simulation in 50 ms steps (service ~step) until ``until()``; then stop it
    for 1 s. Exact in sim time however slow the machine: nothing moves between checks."""
    from geometry_msgs.msg import Twist
    from std_srvs.srv import Empty

    from florence_sim.srv import Step

    pub = publisher("/cmd_vel", Twist)
    wait_for(lambda: pub.get_num_connections() > 0, 30.0, what="cmd_vel subscriber")
    rospy.wait_for_service("/florence_sim/step", 30.0)
    step = rospy.ServiceProxy("/florence_sim/step", Step)
    cmd = Twist()
    cmd.linear.x, cmd.angular.z = v, w

    def advance(steps):
        now = step(steps).sim_time
        # odometry (30 Hz) and ground truth stamped after the steps have reached this process
        wait_for(lambda: min(topics[k].get().header.stamp.to_sec() for k in ("odom", "truth")) >= now - 0.04,
                 30.0, what="odometry after the steps")

    rospy.ServiceProxy("/florence_sim/pause", Empty)()
    try:
        for _ in range(round(max_seconds / 0.05)):
            if until():
                break
            pub.publish(cmd)
            advance(5)
        pub.publish(Twist())
        advance(100)
    finally:
        rospy.ServiceProxy("/florence_sim/unpause", Empty)()


@pytest.fixture(scope="class")
def apartment(ros_master, rospy_node, tf_buffer):
    yield from _launch(ros_master, rospy_node, tf_buffer, f"real_time_factor:={RTF_APARTMENT}",
                       "fake_localization:=true", "x:=1.2", "y:=3.0", "yaw:=0.0")


@pytest.fixture(scope="class")
def apartment_topics(apartment, rospy_node):
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import CameraInfo, Image, PointCloud2
    from std_msgs.msg import Float64, UInt8

    from florence_sim.msg import People

    t = _subscribe(rospy_node, apartment, {
        "clock": ("/clock", Clock),
        "truth": ("/base_pose_ground_truth", Odometry),
        "people": ("/people_ground_truth", People),
        "depth": ("/camera/depth/image", Image),
        "depth_info": ("/camera/depth/camera_info", CameraInfo),
        "rgb": ("/camera/rgb/image_color", Image),
        "points": ("/camera/rgb/points", PointCloud2),
        "tilt": ("/cur_tilt_angle", Float64),
        "tilt_status": ("/cur_tilt_status", UInt8),
    })
    yield t
    _unsubscribe(t)


class TestSmallWorld:
    """A 6 x 6 m room without people."""

    def test_laser_inversion_checked_through_live_tf(self, topics, rospy_node, tf_buffer):
        """The wall on the robot's left appears on its left once the scan goes through tf."""
        import rospy

        _set_pose(rospy_node, 3.0, 2.5, 0.0)
        wait_for(lambda: abs(topics["truth"].get().pose.pose.position.x - 3.0) < 1e-6, 30.0, what="robot at start")
        start = _sim_now(topics)
        wait_for(lambda: topics["scan"].get().header.stamp.to_sec() > start + 0.2, 30.0, what="a fresh scan")
        scan = topics["scan"].get()
        assert scan.header.frame_id == "base_laser_link"
        tf = wait_for(lambda: tf_buffer.lookup_transform("base_footprint", "base_laser_link", rospy.Time(0),
                                                         rospy.Duration(1.0)), 30.0, what="tf base_laser_link")
        laser_in_base = to_matrix(tf)
        ranges = np.array(scan.ranges)
        bearings = scan.angle_min + np.arange(len(ranges)) * scan.angle_increment
        valid = (ranges >= scan.range_min) & (ranges <= scan.range_max)
        local = np.stack([ranges * np.cos(bearings), ranges * np.sin(bearings), np.zeros_like(ranges)], axis=1)[valid]
        base = local @ laser_in_base[:3, :3].T + laser_in_base[:3, 3]
        # robot at (3.0, 2.5) facing +x: the north wall face (y = 5.95) is 3.45 m to its left,
        # the south wall face (y = 0.05) 2.45 m to its right
        sideways = base[np.abs(base[:, 0]) < 0.2]
        left = sideways[sideways[:, 1] > 0]
        right = sideways[sideways[:, 1] < 0]
        assert len(left) and len(right), "beams straight to both sides"
        # range noise is 1 % of the range (sigma 0.035 m at 3.45 m): medians, and every point within 5 sigma
        assert np.median(left[:, 1]) == pytest.approx(3.45, abs=0.04) and np.all(np.abs(left[:, 1] - 3.45) < 0.18)
        assert np.median(right[:, 1]) == pytest.approx(-2.45, abs=0.04) and np.all(np.abs(right[:, 1] + 2.45) < 0.13)
        # and the transformed scan matches the room: the east wall (face x = 5.95) is 2.95 m ahead
        ahead = base[np.abs(base[:, 1]) < 0.1]
        assert len(ahead) and np.median(ahead[:, 0]) == pytest.approx(2.95, abs=0.04)

    def test_sim_time_advances_at_the_requested_factor(self, topics):
        s0, w0 = _sim_now(topics), time.monotonic()
        wait_for(lambda: time.monotonic() - w0 > 3.0, 10.0)
        factor = (_sim_now(topics) - s0) / (time.monotonic() - w0)
        # never faster than requested; slower only as far as a loaded machine explains
        assert 0.5 * RTF < factor < 1.1 * RTF, f"achieved {factor:.2f}x, requested {RTF}x"

    def test_straight_metre_and_quarter_turn_end_near_ground_truth(self, topics, rospy_node, publisher):
        _set_pose(rospy_node, 3.0, 2.5, 0.0)
        wait_for(lambda: topics["truth"].get().pose.pose.position.x == 3.0, 10.0, what="robot at the start")
        odom0 = topics["odom"].get().pose.pose
        truth0 = topics["truth"].get().pose.pose

        def odom_distance():
            p = topics["odom"].get().pose.pose.position
            return math.hypot(p.x - odom0.position.x, p.y - odom0.position.y)

        _stepped_drive(rospy_node, publisher, topics, 0.3, 0.0, lambda: odom_distance() >= 1.0, max_seconds=10.0)
        truth = topics["truth"].get().pose.pose
        moved = math.hypot(truth.position.x - truth0.position.x, truth.position.y - truth0.position.y)
        # at most one 50 ms step past the metre, 0.045 m to stop, 1 % odometry scale error
        assert 0.98 < moved < 1.08
        assert moved * 1.01 == pytest.approx(odom_distance(), abs=0.02), "odometry agrees with ground truth"
        assert abs(yaw_of(truth.orientation)) < math.radians(2)

        yaw0 = yaw_of(topics["odom"].get().pose.pose.orientation)
        _stepped_drive(rospy_node, publisher, topics, 0.0, 0.6,
                       lambda: angles.wrap(yaw_of(topics["odom"].get().pose.pose.orientation) - yaw0) >= math.pi / 2,
                       max_seconds=10.0)
        turned = angles.wrap(yaw_of(topics["truth"].get().pose.pose.orientation) - yaw_of(truth.orientation))
        assert turned == pytest.approx(math.pi / 2, abs=math.radians(6))

    def test_collision_stops_robot_sets_bumper_and_counts(self, topics, rospy_node, publisher):
        _set_pose(rospy_node, 4.5, 3.0, 0.0)  # east wall face at x = 5.95
        before = topics["collisions"].get().data
        _drive(publisher, topics, 0.4, 0.0, lambda: topics["state"].get().bumps_wheeldrops != 0, sim_limit=10.0)
        state = topics["state"].get()
        assert state.bumps_wheeldrops & 0b11 == 0b11, "head-on: both bumpers"
        x = topics["truth"].get().pose.pose.position.x
        assert 5.95 - 0.1696 - 0.03 < x <= 5.95 - 0.1696 + 1e-6
        wait_for(lambda: topics["collisions"].get().data == before + 1, 20.0, what="collision counted")

    def test_nan_cmd_vel_is_ignored_with_a_warning(self, small_world, topics, rospy_node, publisher):
        from geometry_msgs.msg import Twist

        _set_pose(rospy_node, 3.0, 3.0, 0.0)
        pub = publisher("/cmd_vel", Twist)
        wait_for(lambda: pub.get_num_connections() > 0, 30.0)
        bad = Twist()
        bad.linear.x = float("nan")
        start = _sim_now(topics)
        for _ in range(5):
            pub.publish(bad)
            time.sleep(0.05)
        wait_for(lambda: "ignoring cmd_vel with NaN/inf" in small_world.output(), 30.0, what="the warning")
        wait_for(lambda: _sim_now(topics) > start + 1.0, 30.0)
        assert topics["truth"].get().pose.pose.position.x == pytest.approx(3.0)
        assert small_world.output().count("ignoring cmd_vel with NaN/inf") == 1, "the warning is throttled"


class TestApartment:
    """The shipped apartment with its two walking people and fake localization."""

    def test_kinect_topics_are_honest(self, apartment_topics):
        depth = apartment_topics["depth"].get()
        assert (depth.encoding, depth.width, depth.height, depth.step) == ("32FC1", 160, 120, 640)
        assert depth.header.frame_id == "camera_depth_optical_frame"
        values = np.frombuffer(depth.data, dtype="<f4")
        finite = values[np.isfinite(values)]
        assert len(finite) > 0.5 * len(values) and finite.min() >= 0.5 and finite.max() <= 4.2
        info = apartment_topics["depth_info"].get()
        assert info.K[0] == pytest.approx(80 / math.tan(math.radians(29)))
        rgb = apartment_topics["rgb"].get()
        assert (rgb.encoding, rgb.width, rgb.height, len(rgb.data)) == ("rgb8", 160, 120, 160 * 120 * 3)
        cloud = apartment_topics["points"].get()
        assert [f.name for f in cloud.fields] == ["x", "y", "z", "rgb"] and cloud.point_step == 16
        assert cloud.header.frame_id == "camera_rgb_optical_frame" and (cloud.width, cloud.height) == (160, 120)

    def test_tilt_moves_the_camera_frame_in_tf(self, apartment_topics, rospy_node, tf_buffer, publisher):
        import rospy
        from std_msgs.msg import Float64

        pub = publisher("/tilt_angle", Float64, latch=True)
        pub.publish(Float64(20.0))
        wait_for(lambda: abs(apartment_topics["tilt"].get().data - 20.0) < 0.1, 60.0, what="cur_tilt_angle at 20 deg")
        assert apartment_topics["tilt_status"].get().data in (0, 4)

        def pitch():
            tf = tf_buffer.lookup_transform("kinect_base_link", "camera_link", rospy.Time(0))
            q = tf.transform.rotation
            return math.degrees(math.asin(max(-1.0, min(1.0, 2 * (q.w * q.y - q.z * q.x)))))

        # positive tilt looks up: a negative pitch about camera_link's y axis (REP 103)
        wait_for(lambda: abs(pitch() + 20.0) < 0.5, 60.0, what="camera_link tilted in tf")
        pub.publish(Float64(0.0))
        wait_for(lambda: abs(apartment_topics["tilt"].get().data) < 0.1, 60.0, what="tilt back at 0")
        wait_for(lambda: apartment_topics["tilt_status"].get().data == 0, 30.0, what="tilt motor stopped")

    def test_people_walk_their_paths(self, apartment_topics):
        first = {p.id: (p.pose.position.x, p.pose.position.y) for p in apartment_topics["people"].get().people}
        assert set(first) == {"alice", "bob"}
        start = _sim_now(apartment_topics)
        wait_for(lambda: _sim_now(apartment_topics) > start + 4.0, 60.0, what="4 s of sim time")
        later = {p.id: p for p in apartment_topics["people"].get().people}
        for pid, (x, y) in first.items():
            p = later[pid]
            assert math.hypot(p.pose.position.x - x, p.pose.position.y - y) > 0.3, f"{pid} walks"
        # bob walks the corridor at y = 6.15 between x = 0.6 and 6.6
        bob = later["bob"].pose.position
        assert bob.y == pytest.approx(6.15, abs=1e-6) and 0.6 - 1e-6 <= bob.x <= 6.6 + 1e-6

    def test_pause_and_step(self, apartment_topics, rospy_node):
        from std_srvs.srv import Empty

        from florence_sim.srv import Now, Step

        rospy_node.wait_for_service("/florence_sim/pause", 30.0)
        now = rospy_node.ServiceProxy("/florence_sim/now", Now)
        rospy_node.ServiceProxy("/florence_sim/pause", Empty)()
        try:
            t0 = _sim_now(apartment_topics)
            wait_for(lambda: _sim_now(apartment_topics) == t0, 5.0)  # clock stops
            time.sleep(0.3)
            frozen = _sim_now(apartment_topics)
            assert now().sim_time == pytest.approx(frozen, abs=1e-6)  # ~now reads the simulation's time
            res = rospy_node.ServiceProxy("/florence_sim/step", Step)(25)
            assert res.sim_time == pytest.approx(frozen + 0.25, abs=1e-6)
            assert now().sim_time == pytest.approx(res.sim_time, abs=1e-6)  # at once, not when the clock arrives
            wait_for(lambda: _sim_now(apartment_topics) == pytest.approx(res.sim_time), 10.0,
                     what="clock after the steps")
        finally:
            rospy_node.ServiceProxy("/florence_sim/unpause", Empty)()
        wait_for(lambda: _sim_now(apartment_topics) > res.sim_time + 0.5, 30.0, what="clock running again")

    def test_person_services(self, apartment_topics, rospy_node):
        from florence_sim.srv import RemovePerson, SetPerson

        rospy_node.wait_for_service("/florence_sim/set_person", 30.0)
        set_person = rospy_node.ServiceProxy("/florence_sim/set_person", SetPerson)
        res = set_person("carol", "{path: [[4.0, 4.5], [4.0, 6.2]]}")  # through the corridor wall
        assert not res.success and "passes through" in res.message and "corridor_s_2" in res.message
        res = set_person("carol", "{pose: [6.3, 4.0, 1.0], shirt: [0, 1, 0]}")
        assert res.success, res.message
        wait_for(lambda: "carol" in {p.id for p in apartment_topics["people"].get().people}, 30.0, what="carol appears")
        res = rospy_node.ServiceProxy("/florence_sim/remove_person", RemovePerson)("carol")
        assert res.success
        wait_for(lambda: "carol" not in {p.id for p in apartment_topics["people"].get().people}, 30.0,
                 what="carol gone")
        assert not rospy_node.ServiceProxy("/florence_sim/remove_person", RemovePerson)("nobody").success

    def test_fake_localization_puts_the_robot_at_ground_truth(self, apartment_topics, tf_buffer):
        import rospy

        def error():
            tf = tf_buffer.lookup_transform("map", "base_footprint", rospy.Time(0))
            truth = apartment_topics["truth"].get().pose.pose.position
            return math.hypot(tf.transform.translation.x - truth.x, tf.transform.translation.y - truth.y)

        wait_for(lambda: error() < 0.02, 30.0, what="map->base_footprint = ground truth")


def test_malformed_world_stops_the_node_with_file_and_field(tmp_path):
    """A private master: the node's private parameters must not leak into other tests."""
    from florence_common.processes import ManagedProcess, RosMaster

    world = tmp_path / "bad.world.yaml"
    world.write_text("map: {resolution: 0.05, bounds: [[0, 0], [4, 4]]}\nobjects:\n  - {type: sofa, pose: [1, 1]}\n")
    master = RosMaster().start()
    node = None
    try:
        node = ManagedProcess(["rosrun", "florence_sim", "florence_sim_node", f"_world:={world}"], env=master.env())
        assert node.proc.wait(60) == 1
        assert f"{world}: objects[0].type: unknown type 'sofa'" in node.output()
    finally:
        if node is not None:
            node.stop()
        master.stop()
