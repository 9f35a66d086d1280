"""The amcl node against map_server and a scripted robot in this test process (no simulator):
the upside-down laser through tf, amcl_pose / particlecloud / map->odom, initialpose, services."""

import collections
import math
import threading

import numpy as np
import pytest
from map_server.mapfile import GridMap, save_map

from florence_common import angles
from florence_common.processes import ManagedProcess, wait_for

pytestmark = pytest.mark.ros


RES = 0.05
LASER_XYZ = (0.06, 0.0, -0.02)  # base_laser_link on the base, rpy (pi, 0, 0): upside down
ANGLES = np.linspace(-2.0862, 2.0862, 683)


def world():
    """6 m x 5 m room: outer walls, an L wall at y = 3 (x < 2.5), a box at x 4.5..5, y 0.75..1.25,
    a wall stub at y = 3.75 (x > 4) and a pillar at x 0.5..0.7, y 1.75..1.95: no rotational symmetry."""
    data = np.zeros((100, 120), dtype=np.int8)
    data[:2, :] = data[-2:, :] = 100
    data[:, :2] = data[:, -2:] = 100
    data[60:62, 0:50] = 100
    data[60:90, 48:50] = 100
    data[15:25, 90:100] = 100
    data[75:77, 80:120] = 100
    data[35:39, 10:14] = 100
    return data


class FakeRobot:
    """Publishes odom -> base_footprint, the laser's static tf and upside-down scans of the grid."""

    def __init__(self, rospy, omap, start):
        import tf2_ros
        from geometry_msgs.msg import TransformStamped
        from sensor_msgs.msg import LaserScan

        self.rospy, self.omap = rospy, omap
        self.true = np.array(start, dtype=float)
        self.odom = np.zeros(3)
        self.velocity = (0.0, 0.0)
        self.lock = threading.Lock()
        self.history = collections.deque(maxlen=400)  # (stamp [s], true pose) of the last 20 s of scans
        self.scan_pub = rospy.Publisher("amcl_test/scan", LaserScan, queue_size=2)
        self.tf_pub = tf2_ros.TransformBroadcaster()
        self.static = tf2_ros.StaticTransformBroadcaster()
        laser = TransformStamped()
        laser.header.stamp = rospy.Time.now()
        laser.header.frame_id, laser.child_frame_id = "amcl_test/base_footprint", "amcl_test/base_laser_link"
        laser.transform.translation.x, laser.transform.translation.y, laser.transform.translation.z = LASER_XYZ
        laser.transform.rotation.x = 1.0  # roll pi
        self.static.sendTransform(laser)
        self.TransformStamped, self.LaserScan = TransformStamped, LaserScan
        self.running = True
        self.thread = threading.Thread(target=self.loop, daemon=True)
        self.thread.start()

    def loop(self):
        rate = self.rospy.Rate(20.0)
        dt = 0.05
        while self.running and not self.rospy.is_shutdown():
            with self.lock:
                v, w = self.velocity
                for pose in (self.true, self.odom):
                    pose += [v * dt * math.cos(pose[2]), v * dt * math.sin(pose[2]), w * dt]
                true, odom = self.true.copy(), self.odom.copy()
            stamp = self.rospy.Time.now()
            with self.lock:
                self.history.append((stamp.to_sec(), true))
            t = self.TransformStamped()
            t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, "amcl_test/odom", "amcl_test/base_footprint"
            t.transform.translation.x, t.transform.translation.y = odom[0], odom[1]
            t.transform.rotation.z, t.transform.rotation.w = math.sin(odom[2] / 2), math.cos(odom[2] / 2)
            self.tf_pub.sendTransform(t)
            self.scan_pub.publish(self.scan(true, stamp))
            rate.sleep()

    def scan(self, pose, stamp):
        c, s = math.cos(pose[2]), math.sin(pose[2])
        lx, ly = pose[0] + c * LASER_XYZ[0], pose[1] + s * LASER_XYZ[0]
        # Upside down: the beam at laser angle a looks along base bearing -a.
        ranges = self.omap.calc_range(np.full(ANGLES.shape, lx), np.full(ANGLES.shape, ly), pose[2] - ANGLES, 5.6)
        msg = self.LaserScan()
        msg.header.stamp, msg.header.frame_id = stamp, "amcl_test/base_laser_link"
        msg.angle_min, msg.angle_max = float(ANGLES[0]), float(ANGLES[-1])
        msg.angle_increment = float(ANGLES[1] - ANGLES[0])
        msg.range_min, msg.range_max = 0.02, 5.6
        msg.ranges = ranges.astype(np.float32).tolist()
        return msg

    def true_at(self, stamp):
        """The true pose when the scan stamped ``stamp`` [s] was taken (a loaded amcl answers late, and the
        robot drives on meanwhile); the current one if that scan is no longer remembered."""
        with self.lock:
            for t, pose in reversed(self.history):
                if t <= stamp + 1e-6:
                    return pose.copy()
            return self.true.copy()

    def stop(self):
        self.running = False
        self.thread.join(2.0)


@pytest.fixture
def setup(rospy_node, ros_master, tmp_path, tf_buffer):
    from amcl.sensor import OccupancyMap

    grid = GridMap(data=world(), resolution=RES, origin=(0.0, 0.0, 0.0))
    _, yaml_path = save_map(grid, str(tmp_path / "world"))
    env = ros_master.env()
    procs = [ManagedProcess(["rosrun", "map_server", "map_server", yaml_path, "__ns:=amcl_test"], env=env)]
    start = (1.0, 1.0, 0.0)
    robot = FakeRobot(rospy_node, OccupancyMap(world(), RES, (0.0, 0.0)), start)
    params = {"odom_frame_id": "amcl_test/odom", "base_frame_id": "amcl_test/base_footprint",
              "global_frame_id": "map", "initial_pose_x": 1.1, "initial_pose_y": 0.9, "initial_pose_a": 0.05,
              "min_particles": 300, "max_particles": 5000, "laser_max_beams": 60, "odom_model_type": "diff-corrected",
              "odom_alpha1": 0.05, "odom_alpha2": 0.05, "odom_alpha3": 0.05, "odom_alpha4": 0.05,
              "update_min_d": 0.05, "update_min_a": 0.1, "resample_interval": 1, "transform_tolerance": 0.5,
              "use_map_topic": True, "recovery_alpha_slow": 0.001, "recovery_alpha_fast": 0.1,
              "off_free_weight": 0.05,
              # as amcl_turtlebot_control.launch ships: without them a set that converged on a wrong pose
              # after global_localization never draws a random pose (a clean run, 1 Dec: still 1.76 m and
              # 3.14 rad off the pose at its scan's time after 90 s)
              "recovery_mean_likelihood": True, "recovery_wait_converged": True}
    argv = ["rosrun", "amcl", "amcl", "__ns:=amcl_test", *(f"_{k}:={v}" for k, v in params.items())]
    procs.append(ManagedProcess(argv, env=env))
    yield robot, procs
    robot.stop()
    for proc in procs:
        print(f"----- {proc.name} -----\n{proc.output()}")  # shown by pytest when the test failed
        proc.stop()
    tf_buffer.clear()  # this test's map -> odom must not mix with later tests' transforms


def test_amcl_tracks_resets_and_relocalizes(setup, tf_buffer):
    import rospy
    from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
    from std_srvs.srv import Empty

    robot, procs = setup
    latest = {}
    rospy.Subscriber("amcl_test/amcl_pose", PoseWithCovarianceStamped, lambda m: latest.__setitem__("pose", m))
    rospy.Subscriber("amcl_test/particlecloud", PoseArray, lambda m: latest.__setitem__("cloud", m))

    def error():
        msg = latest.get("pose")
        if msg is None:
            return None
        p = msg.pose.pose
        yaw = 2 * math.atan2(p.orientation.z, p.orientation.w)
        true = robot.true_at(msg.header.stamp.to_sec())
        return math.hypot(p.position.x - true[0], p.position.y - true[1]), abs(
            angles.diff(yaw, true[2]))

    def converged(tol=0.1, yaw_tol=0.1):
        e = error()
        return e is not None and e[0] < tol and e[1] < yaw_tol

    try:
        wait_for(lambda: "pose" in latest and "cloud" in latest, 60, what="amcl_pose and particlecloud")
        # Drive forward and turn: the estimate follows (the laser is upside down in tf).
        with robot.lock:
            robot.velocity = (0.3, 0.1)
        wait_for(lambda: robot.true[0] > 2.0, 30, what="the robot to drive 1 m")
        with robot.lock:
            robot.velocity = (0.0, 0.0)
        rospy.wait_for_service("amcl_test/request_nomotion_update", timeout=10)
        rospy.ServiceProxy("amcl_test/request_nomotion_update", Empty)()
        wait_for(converged, 20, what="amcl_pose near the truth after driving")
        msg = latest["pose"]
        assert msg.header.frame_id == "map"
        assert 0 < msg.pose.covariance[0] < 0.1 and 0 < msg.pose.covariance[35] < 0.1
        assert len(latest["cloud"].poses) >= 300

        # map -> odom, post-dated by transform_tolerance.
        t = tf_buffer.lookup_transform("map", "amcl_test/odom", rospy.Time(0), rospy.Duration(5.0))
        assert t.header.stamp > rospy.Time.now() + rospy.Duration(0.2)

        # save_pose_rate (default 0.5 Hz) stores the estimate in ~initial_pose_*: compared with the latest
        # published one, read afresh each time (a snapshot taken as the converged check passed could be the
        # pose published before the no-motion update's, up to 0.1 m from the filter's newest: it failed so
        # once in a clean run, 26 Nov)
        wait_for(lambda: abs(rospy.get_param("amcl_test/amcl/initial_pose_x")
                             - latest["pose"].pose.pose.position.x) < 0.05, 10,
                 what="the estimate saved in ~initial_pose_x")

        # set_map replaces the map and re-initialises at the given pose.
        from nav_msgs.srv import GetMap, SetMap

        rospy.wait_for_service("amcl_test/static_map", timeout=10)
        grid = rospy.ServiceProxy("amcl_test/static_map", GetMap)().map
        moved = PoseWithCovarianceStamped()
        moved.header.frame_id = "map"
        moved.pose.pose.position.x, moved.pose.pose.position.y = 3.0, 2.0
        moved.pose.pose.orientation.w = 1.0
        moved.pose.covariance[0] = moved.pose.covariance[7] = moved.pose.covariance[35] = 0.01
        assert rospy.ServiceProxy("amcl_test/set_map", SetMap)(grid, moved).success
        rospy.ServiceProxy("amcl_test/request_nomotion_update", Empty)()
        wait_for(lambda: math.hypot(latest["pose"].pose.pose.position.x - 3.0,
                                    latest["pose"].pose.pose.position.y - 2.0) < 0.5, 20,
                 what="amcl_pose at set_map's initial pose")

        # initialpose resets the filter to the given pose (a wrong one: the estimate jumps there).
        reset = PoseWithCovarianceStamped()
        reset.header.frame_id = "map"
        reset.pose.pose.position.x, reset.pose.pose.position.y = 4.0, 4.0
        reset.pose.pose.orientation.w = 1.0
        reset.pose.covariance[0] = reset.pose.covariance[7] = 0.01
        reset.pose.covariance[35] = 0.01
        pub = rospy.Publisher("amcl_test/initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
        pub.publish(reset)

        def jumped():
            p = latest["pose"].pose.pose.position
            return math.hypot(p.x - 4.0, p.y - 4.0) < 0.5

        wait_for(jumped, 20, what="amcl_pose to jump to the initial pose")

        # global_localization spreads the particles; driving on, it finds the robot again.
        rospy.wait_for_service("amcl_test/global_localization", timeout=10)
        rospy.ServiceProxy("amcl_test/global_localization", Empty)()
        rospy.ServiceProxy("amcl_test/request_nomotion_update", Empty)()
        wait_for(lambda: len(latest["cloud"].poses) > 1000, 20, what="particles spread over the map")
        with robot.lock:
            robot.velocity = (0.2, 0.3)
        wait_for(lambda: converged(0.15, 0.15), 90, what="global localization to converge")
    except Exception:
        last = latest.get("pose")
        age = (rospy.Time.now() - last.header.stamp).to_sec() if last else None
        print("last error", error(), "true now", robot.true, "last amcl_pose", age, "s old")
        raise
    finally:
        with robot.lock:
            robot.velocity = (0.0, 0.0)
        for proc in procs:
            assert proc.running(), proc.output()
