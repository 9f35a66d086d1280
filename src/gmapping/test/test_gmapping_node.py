"""The slam_gmapping node against a scripted robot in this test process (no simulator): the upside-down laser
through tf, map / map_metadata / ~entropy / map -> odom, dynamic_map and map_saver on a half-built map, and
bad input (NaN and inf scans, a laser frame tf does not know, no odometry) skipped with a reason, never a crash.

One node for the module; the tests run in file order."""

import math
import threading

import numpy as np
import pytest

from florence_common.processes import ManagedProcess, wait_for
from florence_harness import laser_scenes

pytestmark = pytest.mark.ros

NS = "gm_test"
WORLD = laser_scenes.room()
START = (2.0, 1.5, 0.0)  # the robot's true start in the room; the map frame starts on it


class FakeRobot:
    """Publishes odom -> base_footprint, the laser's static tf (upside down) and its scans of the room while
    driving at ``velocity``. ``frame``, ``odometry`` and ``spoil`` make bad input."""

    def __init__(self, rospy):
        import tf2_ros
        from geometry_msgs.msg import TransformStamped
        from sensor_msgs.msg import LaserScan

        self.rospy = rospy
        self.true = np.array(START, float)
        self.velocity = (0.0, 0.0)
        self.frame = f"{NS}/base_laser_link"
        self.odometry = True
        self.spoil = None  # fn(ranges) -> ranges
        self.lock = threading.Lock()
        self.TransformStamped, self.LaserScan = TransformStamped, LaserScan
        self.scan_pub = rospy.Publisher(f"{NS}/scan", LaserScan, queue_size=2)
        self.tf_pub = tf2_ros.TransformBroadcaster()
        self.static = tf2_ros.StaticTransformBroadcaster()
        laser = TransformStamped()
        laser.header.stamp = rospy.Time.now()
        laser.header.frame_id, laser.child_frame_id = f"{NS}/base_footprint", f"{NS}/base_laser_link"
        m = laser_scenes.UPSIDE_DOWN
        laser.transform.translation.x, laser.transform.translation.y, laser.transform.translation.z = m[:3, 3]
        laser.transform.rotation.x = 1.0  # roll pi
        self.static.sendTransform(laser)
        self.scans = 0
        self.running = True
        self.thread = threading.Thread(target=self.loop, daemon=True)
        self.thread.start()

    def loop(self):
        rate, dt = self.rospy.Rate(10.0), 0.1
        while self.running and not self.rospy.is_shutdown():
            with self.lock:
                v, w = self.velocity
                p = self.true
                p += [v * dt * math.cos(p[2]), v * dt * math.sin(p[2]), w * dt]
                true, frame, odometry, spoil = p.copy(), self.frame, self.odometry, self.spoil
            stamp = self.rospy.Time.now()
            if odometry:  # perfect odometry, from the start pose
                odom = np.array([*(np.array([[math.cos(-START[2]), -math.sin(-START[2])],
                                             [math.sin(-START[2]), math.cos(-START[2])]]) @ (true[:2] - START[:2])),
                                 true[2] - START[2]])
                t = self.TransformStamped()
                t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, f"{NS}/odom", f"{NS}/base_footprint"
                t.transform.translation.x, t.transform.translation.y = odom[0], odom[1]
                t.transform.rotation.z, t.transform.rotation.w = math.sin(odom[2] / 2), math.cos(odom[2] / 2)
                self.tf_pub.sendTransform(t)
            ranges, angle_min, inc = laser_scenes.scan(WORLD, true, noise=0.005, rng=np.random.default_rng(self.scans))
            if spoil is not None:
                ranges = spoil(ranges)
            msg = self.LaserScan()
            msg.header.stamp, msg.header.frame_id = stamp, frame
            msg.angle_min, msg.angle_increment = angle_min, inc
            msg.angle_max = angle_min + inc * (len(ranges) - 1)
            msg.range_min, msg.range_max = 0.02, 5.6
            msg.ranges = ranges.tolist()
            self.scan_pub.publish(msg)
            self.scans += 1
            rate.sleep()

    def drive(self, v, w):
        with self.lock:
            self.velocity = (v, w)

    def stop(self):
        self.running = False
        self.thread.join(2.0)


@pytest.fixture(scope="module")
def node(rospy_node, ros_master, tf_buffer):
    robot = FakeRobot(rospy_node)
    params = {"base_frame": f"{NS}/base_footprint", "odom_frame": f"{NS}/odom", "map_frame": f"{NS}/map",
              "particles": 10, "sigma": 0.005, "srr": 0.01, "srt": 0.02, "str": 0.01, "stt": 0.02,
              "linearUpdate": 0.2, "angularUpdate": 0.3, "map_update_interval": 1.0, "xmin": -1.0, "ymin": -1.0,
              "xmax": 1.0, "ymax": 1.0, "seed": 1}
    proc = ManagedProcess(["rosrun", "gmapping", "slam_gmapping", f"__ns:={NS}",
                           *(f"_{k}:={v}" for k, v in params.items())], env=ros_master.env())
    yield robot, proc
    robot.stop()
    print(f"----- slam_gmapping -----\n{proc.output()}")  # shown by pytest when a test failed
    proc.stop()
    tf_buffer.clear()


def latest(rospy, topic, msg_class, timeout=30.0):
    return rospy.wait_for_message(topic, msg_class, timeout=timeout)


def test_maps_the_room_with_the_inverted_laser(node, rospy_node, tf_buffer):
    from nav_msgs.msg import MapMetaData, OccupancyGrid
    from std_msgs.msg import Float64

    rospy = rospy_node
    robot, proc = node
    entropies = []
    sub = rospy.Subscriber(f"{NS}/slam_gmapping/entropy", Float64, lambda m: entropies.append(m.data))
    robot.drive(0.3, 0.25)
    wait_for(lambda: robot.true[2] > 1.2, 60, what="the robot to drive an arc")
    robot.drive(0.0, 0.0)
    wait_for(lambda: entropies, 30, what="~entropy")
    sub.unregister()
    assert all(0.0 <= e <= math.log(10) + 1e-6 for e in entropies)
    grid = latest(rospy, f"{NS}/map", OccupancyGrid)  # latched
    meta = latest(rospy, f"{NS}/map_metadata", MapMetaData)
    assert grid.header.frame_id == f"{NS}/map" and meta.width == grid.info.width
    assert grid.info.resolution == pytest.approx(0.05)
    data = np.asarray(grid.data, np.int8).reshape(grid.info.height, grid.info.width)
    occupied = np.argwhere(data == 100)
    assert len(occupied) > 200 and (data == 0).sum() > 2000
    # the occupied cells lie on the room's walls (map frame = the odometry frame, which starts at START)
    ox, oy = grid.info.origin.position.x, grid.info.origin.position.y
    c, s = math.cos(START[2]), math.sin(START[2])
    mx, my = ox + (occupied[:, 1] + 0.5) * 0.05, oy + (occupied[:, 0] + 0.5) * 0.05
    wx, wy = START[0] + c * mx - s * my, START[1] + s * mx + c * my
    near = [min(_to_segment(np.array([x, y]), seg) for seg in WORLD) < 0.06 for x, y in zip(wx, wy, strict=True)]
    assert np.mean(near) > 0.95, np.mean(near)
    # map -> odom: near identity (perfect odometry), stamped ahead of now
    t = tf_buffer.lookup_transform(f"{NS}/map", f"{NS}/odom", rospy.Time(0), rospy.Duration(5.0))
    assert math.hypot(t.transform.translation.x, t.transform.translation.y) < 0.05
    assert t.header.stamp > rospy.Time.now() - rospy.Duration(0.5)
    assert proc.running()


def _to_segment(p, seg):
    a, b = seg[:2], seg[2:]
    u = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + u * (b - a))))


def test_dynamic_map_and_map_saver_while_mapping(node, rospy_node, ros_master, tmp_path):
    """map_saver on a map that is still growing (the robot drives) writes a valid map file pair."""
    from map_server.mapfile import load_map
    from nav_msgs.srv import GetMap

    rospy = rospy_node
    robot, _ = node
    rospy.wait_for_service(f"{NS}/dynamic_map", timeout=10)
    grid = rospy.ServiceProxy(f"{NS}/dynamic_map", GetMap)().map
    assert grid.info.width > 40 and len(grid.data) == grid.info.width * grid.info.height
    robot.drive(0.2, -0.3)
    saver = ManagedProcess(["rosrun", "map_server", "map_saver", "-f", str(tmp_path / "half"), f"__ns:={NS}"],
                           env=ros_master.env())
    try:
        wait_for(lambda: not saver.running(), 60, what="map_saver to finish")
    finally:
        robot.drive(0.0, 0.0)
        print(saver.output())
        saver.stop()
    assert saver.proc.returncode == 0
    saved = load_map(str(tmp_path / "half.yaml"))
    assert saved.resolution == pytest.approx(0.05)
    assert (saved.data == 100).sum() > 200 and (saved.data == 0).sum() > 2000


def diagnostics_text(rospy, timeout=20.0):
    """Every 'Mapping' status message of slam_gmapping seen within ``timeout`` [s], joined."""
    from diagnostic_msgs.msg import DiagnosticArray

    seen = []

    def take(msg):
        seen.extend(f"{s.level} {s.message}" for s in msg.status if s.name.endswith("Mapping"))

    sub = rospy.Subscriber("/diagnostics", DiagnosticArray, take)
    return sub, seen


@pytest.mark.parametrize("kind", ["nan_inf", "laser_frame", "odometry"])
def test_bad_input_is_skipped_with_a_reason(node, rospy_node, kind):
    from nav_msgs.srv import GetMap

    rospy = rospy_node
    robot, proc = node
    expected = {"nan_inf": None, "laser_frame": f"the laser frame '{NS}/nowhere' is not in tf",
                "odometry": "no odometry at the scan's time"}[kind]
    sub, seen = diagnostics_text(rospy)
    try:
        with robot.lock:
            if kind == "nan_inf":
                robot.spoil = lambda r: np.where(np.arange(len(r)) % 3 == 0, np.nan,
                                                 np.where(np.arange(len(r)) % 3 == 1, np.inf, r)).astype(np.float32)
            elif kind == "laser_frame":
                robot.frame = f"{NS}/nowhere"
            else:
                robot.odometry = False
        robot.drive(0.2, 0.3)
        if expected is not None:
            wait_for(lambda: any(expected in s for s in seen), 30, what=f"diagnostics saying {expected!r}")
        else:
            start = robot.scans
            wait_for(lambda: robot.scans > start + 30, 30, what="30 spoilt scans")
        assert proc.running()
        rospy.wait_for_service(f"{NS}/dynamic_map", timeout=10)
        assert len(rospy.ServiceProxy(f"{NS}/dynamic_map", GetMap)().map.data) > 0
    finally:
        robot.drive(0.0, 0.0)
        sub.unregister()
        with robot.lock:
            robot.spoil, robot.frame, robot.odometry = None, f"{NS}/base_laser_link", True
    if kind == "nan_inf":
        assert not any("skipping" in s for s in seen)
        assert "Traceback" not in proc.output()
