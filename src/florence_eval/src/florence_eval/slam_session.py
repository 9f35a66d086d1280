"""Build a map over ROS as the user manual does (7.3), and record what the evaluation needs.

Runs inside a rospy node that the caller initialised, against a master where ``build_map.launch sim:=true``
runs (florence_sim, the filters and the velocity multiplexer, slam_gmapping). :class:`MappingSession` drives a
tour (florence_eval.tour) by publishing geometry_msgs/Twist on the multiplexer's teleop input, as
turtlebot_teleop_key does, from the simulator's ground truth (the person at the keyboard sees the robot),
and records: the true poses, every scan (to ray-trace them from the true poses: what the laser could show),
slam_gmapping's pose of the robot (tf map -> base_footprint) now and then, collisions. Times are simulated
time, from the ground truth's stamps. :func:`save_map` runs map_saver as the manual says.
"""

import math
import time

import numpy as np
import rospy
from geometry_msgs.msg import Twist
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64

from florence_common.processes import ManagedProcess, ProcessError, wait_for
from florence_common_ros import convert
from florence_eval.nav_session import TruthRecorder
from florence_eval.tour import TourDriver

TELEOP = "/cmd_vel_mux/input/teleop"


class MappingSession(TruthRecorder):
    """Drive a tour through the teleop input and record ground truth, scans and slam_gmapping's estimate."""

    def __init__(self, tf_buffer, map_frame="map", base_frame="base_footprint", cmd_topic=TELEOP):
        from florence_sim.msg import People

        super().__init__()
        self.tf_buffer, self.map_frame, self.base_frame = tf_buffer, map_frame, base_frame
        self.people = {}  # id -> (x, y, vx, vy), the latest
        self.scans = []  # (t [s], frame, angle_min, angle_increment, range_min, range_max, ranges float32)
        self.estimates = []  # (t [s], x, y, yaw) of map -> base_footprint
        self.cmd = rospy.Publisher(cmd_topic, Twist, queue_size=1)
        self.processed = 0  # slam_gmapping's processed scans (one ~entropy message each)
        self.subs += [
            rospy.Subscriber("/people_ground_truth", People, self._on_people, queue_size=10),
            rospy.Subscriber("/scan", LaserScan, self._on_scan, queue_size=50, buff_size=2**22),
            rospy.Subscriber("/slam_gmapping/entropy", Float64, self._on_entropy, queue_size=10),
        ]

    def _on_entropy(self, _msg):
        with self.lock:
            self.processed += 1

    def _on_people(self, msg):
        with self.lock:
            self.people = {s.id: (s.pose.position.x, s.pose.position.y, s.velocity.linear.x, s.velocity.linear.y)
                           for s in msg.people}

    def _on_scan(self, msg):
        with self.lock:
            self.scans.append((msg.header.stamp.to_sec(), msg.header.frame_id, msg.angle_min, msg.angle_increment,
                               msg.range_min, msg.range_max, np.asarray(msg.ranges, np.float32)))

    def wait_ready(self, timeout=120.0):
        """Wait (wall time) for ground truth, a scan, slam_gmapping's first processed scan and its map -> base;
        False if they did not come. (Driving before slam_gmapping took its first scan, while it still compiled
        its kernels on a fresh machine, started the map half a turn later: 0.19 m ATE, occupied F1 0.51.)"""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.latest() is not None and self.scans and self.processed and self.estimate() is not None:
                return True
            time.sleep(0.1)
        return False

    def estimate(self):
        """slam_gmapping's latest pose of the robot: (t [s], x, y, yaw) of map -> base_footprint, or None."""
        import tf2_ros

        try:
            t = self.tf_buffer.lookup_transform(self.map_frame, self.base_frame, rospy.Time(0))
        except (tf2_ros.TransformException, rospy.ROSException):
            return None
        return (t.header.stamp.to_sec(), *convert.to_xyyaw(t))

    def drive(self, steps, sim_timeout=900.0, wall_timeout=None, rate=20.0, v_max=0.3, clearance=None, progress=None):
        """Drive the tour ``steps``; stops at the end or after ``sim_timeout`` simulated seconds (and
        ``wall_timeout`` wall seconds, a backstop when the simulation stalls); ``clearance`` lets the driver step
        aside for people (florence_eval.tour.TourDriver). Returns the TourDriver
        (``done``: the tour was completed; ``waited``: seconds it gave way to people)."""
        driver = TourDriver(steps, v_max=v_max, clearance=clearance)
        start = self.sim_now()
        deadline = time.monotonic() + (wall_timeout if wall_timeout is not None else 10.0 * sim_timeout + 60.0)
        last_t, last_estimate = start, -math.inf
        while not driver.done and self.sim_now() - start < sim_timeout and time.monotonic() < deadline:
            truth = self.latest()
            with self.lock:
                people = list(self.people.values())
            v, w = driver.command(truth[1:4], people, dt=max(0.0, truth[0] - last_t))
            last_t = truth[0]
            self.cmd.publish(Twist(linear=_vector(v), angular=_vector(0.0, 0.0, w)))
            if truth[0] - last_estimate >= 0.5:
                est = self.estimate()
                if est is not None:
                    with self.lock:
                        self.estimates.append(est)
                    last_estimate = truth[0]
                if progress is not None:
                    progress(self, driver)
            time.sleep(1.0 / rate)
        for _ in range(3):
            self.cmd.publish(Twist())
            time.sleep(0.05)
        return driver

    def truth_arrays(self):
        """(times [N] [s], poses [N, 3] (x, y, yaw)) of the ground truth so far."""
        rows = self.track()
        return rows[:, 0], rows[:, 1:4]


def _vector(x, y=0.0, z=0.0):
    from geometry_msgs.msg import Vector3

    return Vector3(x, y, z)


def save_map(master, path, timeout=120.0):
    """``rosrun map_server map_saver -f path`` against ``master`` (a florence_common.processes.RosMaster), as
    the manual says; returns the map's YAML path. Raises RuntimeError (with map_saver's output) when it fails."""
    proc = ManagedProcess(["rosrun", "map_server", "map_saver", "-f", str(path)], env=master.env())
    try:
        wait_for(lambda: not proc.running(), timeout, what="map_saver to write the map")
    except ProcessError:
        pass
    finally:
        proc.stop()
    if proc.proc.returncode != 0:
        raise RuntimeError(f"map_saver failed ({proc.proc.returncode}):\n{proc.output()}")
    return f"{path}.yaml"


def scans_for_judging(session, laser_pose, max_range, usable=None):
    """(true base poses [N, 3], scans [(LaserGeometry, ranges, usable, max_range)]) of the session's scans taken
    while ground truth ran, for florence_eval.slam_metrics.seen_map; ``laser_pose`` the laser's 4x4 pose on the
    base (from the robot description)."""
    from gmapping.laser import LaserGeometry, usable_ranges

    from florence_eval.tour import interpolate_poses

    times, truth = session.truth_arrays()
    with session.lock:
        scans = list(session.scans)
    stamps = np.array([s[0] for s in scans])
    poses = interpolate_poses(times, truth, stamps)
    keep = np.isfinite(poses).all(axis=1)
    lasers, out = {}, []
    for (_, _, angle_min, inc, range_min, _, ranges), ok in zip(scans, keep, strict=True):
        if not ok:
            continue
        key = (angle_min, inc, len(ranges))
        if key not in lasers:
            lasers[key] = LaserGeometry.from_transform(laser_pose, angle_min, inc, len(ranges))
        reach = usable if usable is not None else max_range
        out.append((lasers[key], usable_ranges(ranges, range_min, max_range), reach, max_range))
    return poses[keep], out
