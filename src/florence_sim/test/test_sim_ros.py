"""florence_sim on ROS: florence_sim.launch against a private master, faster than real time.

One launch of a small synthetic world serves the motion, laser-through-tf, bumper and
time tests; a second runs the shipped apartment with its people and cameras.
"""

import math
import threading
import time

import numpy as np
import pytest

from florence_harness.processes import roslaunch, wait_for

RTF = 3.0
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
    """Keeps the last message of a topic and counts messages."""

    def __init__(self, rospy, topic, cls):
        self.msg, self.count, self.lock = None, 0, threading.Lock()
        self.sub = rospy.Subscriber(topic, cls, self._cb, queue_size=5)

    def _cb(self, msg):
        with self.lock:
            self.msg, self.count = msg, self.count + 1

    def get(self):
        with self.lock:
            return self.msg


@pytest.fixture(scope="module")
def sim(ros_master, rospy_node, tmp_path_factory):
    import pathlib

    types = pathlib.Path(__file__).resolve().parents[3] / "maps" / "florence_types.yaml"
    world = tmp_path_factory.mktemp("world") / "test.world.yaml"
    world.write_text(WORLD.format(types=types))
    nobody = world.parent / "nobody.yaml"
    nobody.write_text("people: []\n")
    proc = roslaunch(ros_master, "florence_sim", "florence_sim.launch", f"world:={world}", f"people:={nobody}",
                     f"real_time_factor:={RTF}", "x:=3.0", "y:=2.5", "yaw:=0.0")
    try:
        yield proc
    finally:
        proc.stop()


@pytest.fixture(scope="module")
def topics(sim, rospy_node):
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import UInt32

    from turtlebot_node.msg import TurtlebotSensorState

    rospy = rospy_node
    t = {
        "clock": Latest(rospy, "/clock", Clock),
        "odom": Latest(rospy, "/odom", Odometry),
        "truth": Latest(rospy, "/base_pose_ground_truth", Odometry),
        "scan": Latest(rospy, "/scan", LaserScan),
        "state": Latest(rospy, "/turtlebot_node/sensor_state", TurtlebotSensorState),
        "collisions": Latest(rospy, "/collisions", UInt32),
    }
    wait_for(lambda: all(v.get() is not None for v in t.values()) or not sim.running(), 90.0,
             what="every simulator topic")
    assert sim.running(), sim.output()
    yield t
    for v in t.values():
        v.sub.unregister()


def _yaw(q):
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def _wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def _set_pose(rospy, x, y, yaw):
    from florence_sim.srv import SetRobotPose

    rospy.wait_for_service("/florence_sim/set_robot_pose", 30.0)
    res = rospy.ServiceProxy("/florence_sim/set_robot_pose", SetRobotPose)(x, y, yaw)
    assert res.success, res.message


def _sim_now(topics):
    return topics["clock"].get().clock.to_sec()


def _drive(rospy, topics, v, w, until, sim_limit):
    """Publish cmd_vel at 50 Hz (wall) until ``until()`` or ``sim_limit`` simulated seconds pass; then stop."""
    from geometry_msgs.msg import Twist

    pub = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
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
        pub.unregister()


@pytest.mark.ros
def test_laser_inversion_checked_through_live_tf(topics, rospy_node, tf_buffer):
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
    q = tf.transform.rotation
    rot = np.array([[1 - 2 * (q.y ** 2 + q.z ** 2), 2 * (q.x * q.y - q.z * q.w), 2 * (q.x * q.z + q.y * q.w)],
                    [2 * (q.x * q.y + q.z * q.w), 1 - 2 * (q.x ** 2 + q.z ** 2), 2 * (q.y * q.z - q.x * q.w)],
                    [2 * (q.x * q.z - q.y * q.w), 2 * (q.y * q.z + q.x * q.w), 1 - 2 * (q.x ** 2 + q.y ** 2)]])
    trans = np.array([tf.transform.translation.x, tf.transform.translation.y, tf.transform.translation.z])
    ranges = np.array(scan.ranges)
    angles = scan.angle_min + np.arange(len(ranges)) * scan.angle_increment
    valid = (ranges >= scan.range_min) & (ranges <= scan.range_max)
    local = np.stack([ranges * np.cos(angles), ranges * np.sin(angles), np.zeros_like(ranges)], axis=1)[valid]
    base = local @ rot.T + trans
    # robot at (3.0, 2.5) facing +x: the north wall face (y = 5.95) is 3.45 m to its left,
    # the south wall face (y = 0.05) 2.45 m to its right
    sideways = base[np.abs(base[:, 0]) < 0.2]
    left = sideways[sideways[:, 1] > 0]
    right = sideways[sideways[:, 1] < 0]
    assert len(left) and len(right), "beams straight to both sides"
    assert np.allclose(left[:, 1], 3.45, atol=0.06), left
    assert np.allclose(right[:, 1], -2.45, atol=0.06), right
    # and the transformed scan matches the room: the east wall (face x = 5.95) is 2.95 m ahead
    ahead = base[np.abs(base[:, 1]) < 0.1]
    assert np.allclose(ahead[:, 0], 2.95, atol=0.06)


@pytest.mark.ros
def test_sim_time_advances_at_the_requested_factor(topics):
    s0, w0 = _sim_now(topics), time.monotonic()
    wait_for(lambda: time.monotonic() - w0 > 3.0, 10.0)
    factor = (_sim_now(topics) - s0) / (time.monotonic() - w0)
    assert 0.6 * RTF < factor < 1.1 * RTF, f"achieved {factor:.2f}x, requested {RTF}x"


@pytest.mark.ros
def test_straight_metre_and_quarter_turn_end_near_ground_truth(topics, rospy_node):
    _set_pose(rospy_node, 3.0, 2.5, 0.0)
    odom0 = topics["odom"].get().pose.pose
    truth0 = topics["truth"].get().pose.pose
    wait_for(lambda: topics["truth"].get().pose.pose.position.x == 3.0, 10.0)

    def odom_distance():
        p = topics["odom"].get().pose.pose.position
        return math.hypot(p.x - odom0.position.x, p.y - odom0.position.y)

    _drive(rospy_node, topics, 0.3, 0.0, lambda: odom_distance() >= 1.0, sim_limit=10.0)
    wait_for(lambda: abs(topics["truth"].get().twist.twist.linear.x) < 1e-6, 20.0, what="robot stopped")
    truth = topics["truth"].get().pose.pose
    moved = math.hypot(truth.position.x - truth0.position.x, truth.position.y - truth0.position.y)
    assert moved == pytest.approx(1.0, abs=0.08)  # stopping distance + 1 % scale error
    assert abs(_yaw(truth.orientation)) < math.radians(3)

    yaw0 = _yaw(topics["odom"].get().pose.pose.orientation)
    _drive(rospy_node, topics, 0.0, 0.6,
           lambda: _wrap(_yaw(topics["odom"].get().pose.pose.orientation) - yaw0) >= math.pi / 2,
           sim_limit=10.0)
    wait_for(lambda: abs(topics["truth"].get().twist.twist.angular.z) < 1e-6, 20.0, what="robot stopped")
    turned = _wrap(_yaw(topics["truth"].get().pose.pose.orientation) - _yaw(truth.orientation))
    assert turned == pytest.approx(math.pi / 2, abs=math.radians(8))


@pytest.mark.ros
def test_collision_stops_robot_sets_bumper_and_counts(topics, rospy_node):
    _set_pose(rospy_node, 4.5, 3.0, 0.0)  # east wall face at x = 5.95
    before = topics["collisions"].get().data
    _drive(rospy_node, topics, 0.4, 0.0, lambda: topics["state"].get().bumps_wheeldrops != 0, sim_limit=10.0)
    state = topics["state"].get()
    assert state.bumps_wheeldrops & 0b11 == 0b11, "head-on: both bumpers"
    x = topics["truth"].get().pose.pose.position.x
    assert 5.95 - 0.1696 - 0.03 < x <= 5.95 - 0.1696 + 1e-6
    wait_for(lambda: topics["collisions"].get().data == before + 1, 20.0, what="collision counted")


@pytest.mark.ros
def test_nan_cmd_vel_is_ignored_with_a_warning(sim, topics, rospy_node):
    from geometry_msgs.msg import Twist

    _set_pose(rospy_node, 3.0, 3.0, 0.0)
    pub = rospy_node.Publisher("/cmd_vel", Twist, queue_size=1)
    wait_for(lambda: pub.get_num_connections() > 0, 30.0)
    bad = Twist()
    bad.linear.x = float("nan")
    start = _sim_now(topics)
    for _ in range(5):
        pub.publish(bad)
        time.sleep(0.05)
    pub.unregister()
    wait_for(lambda: "ignoring cmd_vel with NaN/inf" in sim.output(), 30.0, what="the warning")
    wait_for(lambda: _sim_now(topics) > start + 1.0, 30.0)
    assert topics["truth"].get().pose.pose.position.x == pytest.approx(3.0)
    assert sim.output().count("ignoring cmd_vel with NaN/inf") == 1, "the warning is throttled"
