"""amcl node: the ROS amcl interface around :class:`amcl.localizer.Localizer`.

ROS Parameters: amcl.params.FILTER and NODE, ROS amcl's names and defaults (rendered in the README).

ROS Publishers:
    amcl_pose (geometry_msgs/PoseWithCovarianceStamped, latched): the estimate after each resampling.
    particlecloud (geometry_msgs/PoseArray): the particles.
    tf: map -> odom, stamped scan time + transform_tolerance.
    ~update_duration (std_msgs/Float64, s): wall time of each filter update (Florence addition, for profiling).
    /diagnostics: the map, the particle set, updates and why scans were skipped.

ROS Subscribers:
    scan (sensor_msgs/LaserScan), initialpose (geometry_msgs/PoseWithCovarianceStamped),
    map (nav_msgs/OccupancyGrid, with use_map_topic).

ROS Services:
    global_localization (std_srvs/Empty), request_nomotion_update (std_srvs/Empty),
    set_map (nav_msgs/SetMap).
Services called:
    static_map (nav_msgs/GetMap), without use_map_topic.
"""

import threading
import time

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Point, Pose, PoseArray, PoseWithCovarianceStamped, Quaternion
from nav_msgs.msg import OccupancyGrid
from nav_msgs.srv import GetMap, SetMap, SetMapResponse
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64
from std_srvs.srv import Empty, EmptyResponse

from amcl.localizer import Localizer, config_from_params, map_to_odom
from amcl.params import NODE
from amcl.sensor import beams_in_base
from florence_common.pose import compose, yaw_to_quaternion
from florence_common_ros.convert import pose_msg, quaternion_tuple, to_xyyaw, transform_stamped, yaw_of
from florence_common_ros.diagnostics import ERROR, OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run

LOG = "amcl: "


def read_config():
    """Every filter parameter from ~ with the ROS defaults (ValueError names a bad one)."""
    return config_from_params(lambda name, default: rospy.get_param("~" + name, default))


class AmclNode:
    """One amcl instance: parameters, the localizer, and its ROS connections."""

    def __init__(self, rng=None):
        self.config = read_config()
        p = read_params(NODE)
        self.transform_tolerance = rospy.Duration(p.transform_tolerance)
        self.init_mean = np.array([p.initial_pose_x, p.initial_pose_y, p.initial_pose_a])
        self.init_cov = np.diag([p.initial_cov_xx, p.initial_cov_yy, p.initial_cov_aa])
        self.save_period = rospy.Duration(1.0 / p.save_pose_rate) if p.save_pose_rate > 0 else None
        self.use_map_topic = p.use_map_topic
        self.first_map_only = p.first_map_only
        self.odom_frame, self.base_frame, self.global_frame = p.odom_frame_id, p.base_frame_id, p.global_frame_id
        self.tf_broadcast = p.tf_broadcast
        self.skipped = {}  # reason -> scans skipped for it
        self.updates = 0

        self.lock = threading.RLock()
        self.localizer = Localizer(self.config, rng)
        self.have_map = False
        self.laser_geometry = {}  # laser frame -> (laser_xy, rotation quaternion)
        self.last_map_to_odom = None
        self.last_published_cov = None  # the covariance of the last amcl_pose
        self.last_save = None
        self.force_publish = True  # publish the first estimate after a (re)initialisation

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.tf_pub = tf2_ros.TransformBroadcaster()
        self.pose_pub = rospy.Publisher("amcl_pose", PoseWithCovarianceStamped, queue_size=2, latch=True)
        self.cloud_pub = rospy.Publisher("particlecloud", PoseArray, queue_size=2, latch=True)
        self.duration_pub = rospy.Publisher("~update_duration", Float64, queue_size=10)
        self.diag = Diagnostics("amcl")
        self.diag.add("Localization", self._diagnose)
        self.services = [
            rospy.Service("global_localization", Empty, self.on_global_localization),
            rospy.Service("request_nomotion_update", Empty, self.on_nomotion_update),
            rospy.Service("set_map", SetMap, self.on_set_map),
        ]
        self.initialpose_sub = rospy.Subscriber("initialpose", PoseWithCovarianceStamped, self.on_initialpose,
                                                queue_size=2)
        self.map_sub = None
        if self.use_map_topic:
            self.map_sub = rospy.Subscriber("map", OccupancyGrid, self.on_map, queue_size=1)
            rospy.loginfo(LOG + "waiting for a map on %s", rospy.resolve_name("map"))
        else:
            self.request_static_map()
        self.scan_sub = rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=1, buff_size=2**22)

    # ---- map -------------------------------------------------------------------------
    def request_static_map(self):
        """Block until static_map answers (ROS amcl does the same at start-up)."""
        name = rospy.resolve_name("static_map")
        rospy.loginfo(LOG + "requesting the map from %s", name)
        while not rospy.is_shutdown():
            try:
                rospy.wait_for_service(name, timeout=2.0)
                self.on_map(rospy.ServiceProxy(name, GetMap)().map)
                return
            except (rospy.ROSException, rospy.ServiceException) as exc:
                rospy.logwarn_throttle(10.0, LOG + f"no map from {name} yet ({exc}); retrying")

    def on_map(self, msg, initial_pose=None):
        with self.lock:
            if self.have_map and self.first_map_only:
                rospy.logdebug(LOG + "first_map_only: ignoring a new map")
                return
            info = msg.info
            if info.width * info.height != len(msg.data) or info.width == 0 or not info.resolution > 0:
                rospy.logwarn(LOG + "ignoring a map with %d cells for %d x %d at resolution %r",
                              len(msg.data), info.width, info.height, info.resolution)
                return
            if abs(yaw_of(info.origin.orientation)) > 1e-6:
                rospy.logwarn(LOG + "the map's origin is rotated; like ROS amcl the rotation is ignored")
            data = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
            self.localizer.set_map(data, info.resolution, (info.origin.position.x, info.origin.position.y))
            self.have_map = True
            if not self.localizer.map.has_free_cells:
                rospy.logwarn(LOG + "the map has no free cells; scans will be ignored")
            mean, cov = initial_pose if initial_pose is not None else (self.init_mean, self.init_cov)
            self.localizer.set_pose(mean, cov)
            self.force_publish = True
            rospy.loginfo(LOG + "map %d x %d at %.3f m/cell; %d particles around (%.2f, %.2f, %.2f)",
                          info.width, info.height, info.resolution, len(self.localizer.pf), *mean)

    # ---- services and initial pose ---------------------------------------------------
    def on_global_localization(self, _req):
        with self.lock:
            try:
                self.localizer.global_localization()
                self.force_publish = True
                self.publish_cloud(rospy.Time.now())  # the spread set at once, before the next scan update
                rospy.loginfo(LOG + "global localization: %d particles over the free space",
                              len(self.localizer.pf))
            except ValueError as exc:
                rospy.logwarn(LOG + f"global localization refused: {exc}")
        return EmptyResponse()

    def on_nomotion_update(self, _req):
        with self.lock:
            self.localizer.request_nomotion_update()
        return EmptyResponse()

    def on_set_map(self, req):
        pose = self.pose_from_msg(req.initial_pose)
        with self.lock:
            self.have_map = False  # set_map replaces the map even with first_map_only
            self.on_map(req.map, pose)
        return SetMapResponse(success=self.have_map)

    def pose_from_msg(self, msg):
        """PoseWithCovarianceStamped to (mean, cov 3x3) or None if unusable (warned)."""
        frame = msg.header.frame_id.lstrip("/")
        if frame == "":
            rospy.logwarn(LOG + "initial pose has an empty frame_id; assuming %s", self.global_frame)
        elif frame != self.global_frame:
            rospy.logwarn(LOG + "ignoring an initial pose in frame '%s': it must be in '%s'", frame, self.global_frame)
            return None
        p = msg.pose.pose
        mean = np.array([p.position.x, p.position.y, yaw_of(p.orientation)])
        c = np.asarray(msg.pose.covariance, dtype=float)
        cov = np.array([[c[0], c[1], 0.0], [c[6], c[7], 0.0], [0.0, 0.0, c[35]]])
        if not (np.isfinite(mean).all() and np.isfinite(cov).all()):
            rospy.logwarn(LOG + "ignoring an initial pose with NaN or inf values")
            return None
        return mean, cov

    def on_initialpose(self, msg):
        pose = self.pose_from_msg(msg)
        if pose is None:
            return
        with self.lock:
            self.init_mean, self.init_cov = pose
            if self.have_map:
                self.localizer.set_pose(*pose)
                self.force_publish = True
                rospy.loginfo(LOG + "initial pose set to (%.3f, %.3f, %.3f)", *pose[0])

    # ---- scans -----------------------------------------------------------------------
    def lookup_2d(self, target, source, stamp, timeout=0.2):
        t = self.tf_buffer.lookup_transform(target, source, stamp, rospy.Duration(timeout))
        return np.array(to_xyyaw(t)), t

    def laser_pose(self, frame):
        if frame not in self.laser_geometry:
            t = self.tf_buffer.lookup_transform(self.base_frame, frame, rospy.Time(0), rospy.Duration(1.0))
            tr = t.transform.translation
            self.laser_geometry[frame] = ((tr.x, tr.y, tr.z), quaternion_tuple(t.transform.rotation))
        return self.laser_geometry[frame]

    def _skip(self, reason):
        self.skipped[reason] = self.skipped.get(reason, 0) + 1
        rospy.logwarn_throttle(5.0, LOG + f"skipping a scan: {reason}")

    def on_scan(self, scan):
        frame = scan.header.frame_id.lstrip("/")
        try:
            translation, quaternion = self.laser_pose(frame)
            odom_pose, _ = self.lookup_2d(self.odom_frame, self.base_frame, scan.header.stamp)
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as exc:
            self._skip(f"no transform ({exc})")
            return
        n = len(scan.ranges)
        angles = scan.angle_min + scan.angle_increment * np.arange(n)
        laser_xy, bearings = beams_in_base(translation, quaternion, angles)
        with self.lock:
            if not self.have_map:
                return
            start = time.perf_counter()
            result = self.localizer.process_scan(odom_pose, laser_xy, bearings, np.asarray(scan.ranges, dtype=float),
                                                 scan.range_min, scan.range_max)
            elapsed = time.perf_counter() - start
            if result.updated:
                self.updates += 1
                self.last_update_ms = 1000.0 * elapsed
                self.duration_pub.publish(Float64(elapsed))
                self.publish_cloud(scan.header.stamp)
                if result.resampled or self.force_publish:
                    self.force_publish = False
                    self.publish_pose(result, scan.header.stamp)
                    self.last_map_to_odom = map_to_odom(result.pose, odom_pose)
                    self.last_published_cov = result.cov
            elif result.reason not in ("", "not moved enough"):
                self._skip(result.reason)
            if self.last_map_to_odom is not None and self.tf_broadcast:
                self.publish_tf(self.last_map_to_odom, scan.header.stamp + self.transform_tolerance)
            if self.last_map_to_odom is not None and self.last_published_cov is not None:
                # as ROS's amcl saves it: the published map -> odom applied to the latest odometry (not a
                # filter estimate that was never published: a no-motion update without a resample is not)
                self.maybe_save_pose(compose(self.last_map_to_odom, odom_pose), self.last_published_cov)

    def publish_pose(self, result, stamp):
        msg = PoseWithCovarianceStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.global_frame
        msg.pose.pose = pose_msg(*(float(v) for v in result.pose))
        cov = [0.0] * 36
        cov[0], cov[1], cov[6], cov[7] = (float(v) for v in result.cov[:2, :2].ravel())
        cov[35] = float(result.cov[2, 2])
        msg.pose.covariance = cov
        self.pose_pub.publish(msg)

    def publish_cloud(self, stamp):
        msg = PoseArray()
        msg.header.stamp, msg.header.frame_id = stamp, self.global_frame
        particles = self.localizer.pf.particles
        quaternions = yaw_to_quaternion(particles[:, 2]).reshape(-1, 4)  # all at once: thousands of particles
        for (x, y, _), (qx, qy, qz, qw) in zip(particles.tolist(), quaternions.tolist(), strict=True):
            msg.poses.append(Pose(Point(x, y, 0.0), Quaternion(qx, qy, qz, qw)))
        self.cloud_pub.publish(msg)

    def publish_tf(self, transform, stamp):
        self.tf_pub.sendTransform(transform_stamped(stamp, self.global_frame, self.odom_frame, *transform))

    def maybe_save_pose(self, pose, cov):
        if self.save_period is None:
            return
        now = rospy.Time.now()
        if self.last_save is not None and now - self.last_save < self.save_period:
            return
        self.last_save = now
        saved = {"initial_pose_x": pose[0], "initial_pose_y": pose[1], "initial_pose_a": pose[2],
                 "initial_cov_xx": cov[0, 0], "initial_cov_yy": cov[1, 1], "initial_cov_aa": cov[2, 2]}
        for name, value in saved.items():
            rospy.set_param(f"~{name}", float(value))


    def _diagnose(self, stat):
        with self.lock:
            have_map, n = self.have_map, len(self.localizer.pf) if self.have_map else 0
            estimate = self.localizer.last_estimate
        if not have_map:
            stat.summary(ERROR, "no map yet")
        elif self.skipped:
            reasons = "; ".join(f"{k} ({v})" for k, v in sorted(self.skipped.items()))
            stat.summary(WARN, f"scans skipped: {reasons}"[:200])
        else:
            stat.summary(OK, f"localizing with {n} particles")
        self.skipped = {}
        stat.add("particles", n)
        stat.add("filter updates", self.updates)
        stat.add("last update (ms)", f"{getattr(self, 'last_update_ms', 0.0):.1f}")
        if estimate is not None:
            pose, cov = estimate
            stat.add("pose (x, y, yaw)", f"{pose[0]:.3f}, {pose[1]:.3f}, {pose[2]:.3f}")
            std = np.sqrt(np.diag(cov))
            stat.add("std x, y (m), yaw (rad)", f"{std[0]:.3f}, {std[1]:.3f}, {std[2]:.3f}")
        return stat


def main():
    run(AmclNode, "amcl")
