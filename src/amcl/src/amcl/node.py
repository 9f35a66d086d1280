"""amcl node: the ROS amcl interface around :class:`amcl.localizer.Localizer`.

ROS Parameters (ROS amcl names and defaults):
    ~min_particles (int, 100): fewest particles.
    ~max_particles (int, 5000): most particles.
    ~kld_err (double, 0.01): KLD-sampling error bound.
    ~kld_z (double, 0.99): KLD-sampling normal quantile (used as given, like ROS).
    ~update_min_d (double, 0.2, m): translation in x or y before a filter update.
    ~update_min_a (double, pi/6, rad): rotation before a filter update.
    ~resample_interval (int, 2): filter updates per resampling.
    ~selective_resampling (bool, false): resample only when N_eff < N/2.
    ~transform_tolerance (double, 0.1, s): map->odom is post-dated by this much.
    ~recovery_alpha_slow (double, 0.0): slow average decay (0 disables random poses).
    ~recovery_alpha_fast (double, 0.0): fast average decay.
    ~recovery_mean_likelihood (bool, false): Florence addition: the recovery averages follow the set's
        mean sensor likelihood (Probabilistic Robotics) instead of ROS's mean divided by the particle count,
        which KLD-sampling's shrinking set inflates so that random poses are never injected (false: ROS).
    ~recovery_wait_converged (bool, false): Florence addition: after an initialisation the recovery averages
        start once the set has converged (all particles within 0.5 m of the mean), not from the likelihood of a
        set spread by global_localization, which keeps w_slow so low that a wrong pose never draws random poses.
    ~initial_pose_x, ~initial_pose_y (double, 0.0, m), ~initial_pose_a (double, 0.0, rad): initial mean.
    ~initial_cov_xx, ~initial_cov_yy (double, 0.25, m^2), ~initial_cov_aa (double, (pi/12)^2, rad^2).
    ~gui_publish_rate (double, -1.0, Hz): accepted and unused, as in ROS noetic amcl (particlecloud
        goes out with every filter update).
    ~save_pose_rate (double, 0.5, Hz): how often the estimate is stored in ~initial_pose_* and
        ~initial_cov_* (-1 disables).
    ~use_map_topic (bool, false): take the map from the map topic instead of the static_map service.
    ~first_map_only (bool, false): ignore maps after the first.
    ~laser_min_range, ~laser_max_range (double, -1.0, m): override the scan's limits when > 0.
    ~laser_max_beams (int, 30): beams used per scan (evenly spaced).
    ~laser_z_hit (0.95), ~laser_z_short (0.1), ~laser_z_max (0.05), ~laser_z_rand (0.05) (double):
        mixture weights.
    ~laser_sigma_hit (double, 0.2, m): std dev of the hit term.
    ~laser_lambda_short (double, 0.1, 1/m): exponential rate of the short term (beam model).
    ~laser_likelihood_max_dist (double, 2.0, m): cap of the likelihood field's distance.
    ~laser_model_type (str, "likelihood_field"): "likelihood_field", "likelihood_field_prob" (ROS's product of
        the beams' pz, without beam skipping) or "beam".
    ~laser_likelihood_interpolate (bool, false): Florence addition: the likelihood field's distance is
        interpolated between cell centres and signed: the surface runs through the outermost occupied cells'
        centres and an endpoint inside an obstacle counts its depth (false: ROS's cell lookup, 0 inside).
    ~odom_model_type (str, "diff"): "diff" (ROS's original) or "diff-corrected".
    ~odom_alpha1..4 (double, 0.2): rotation/translation noise; ~odom_alpha5 (0.2): unused (omni only).
    ~odom_frame_id (str, "odom"), ~base_frame_id (str, "base_link"), ~global_frame_id (str, "map").
    ~tf_broadcast (bool, true): publish map->odom.
    ~off_free_weight (double, 1.0): Florence addition: factor on the sensor likelihood of particles that are
        not on a free map cell (inside furniture, walls, unknown space or off the map); 1.0 is ROS amcl.

Publishers:
    amcl_pose (geometry_msgs/PoseWithCovarianceStamped, latched): the estimate after each resampling.
    particlecloud (geometry_msgs/PoseArray): the particles.
    tf: map -> odom, stamped scan time + transform_tolerance.
    ~update_duration (std_msgs/Float64, s): wall time of each filter update (Florence addition, for profiling).

Subscribers:
    scan (sensor_msgs/LaserScan), initialpose (geometry_msgs/PoseWithCovarianceStamped),
    map (nav_msgs/OccupancyGrid, with use_map_topic).

Services:
    global_localization (std_srvs/Empty), request_nomotion_update (std_srvs/Empty),
    set_map (nav_msgs/SetMap).
Services called:
    static_map (nav_msgs/GetMap), without use_map_topic.
"""

import math
import threading
import time

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Pose, PoseArray, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import OccupancyGrid
from nav_msgs.srv import GetMap, SetMap, SetMapResponse
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64
from std_srvs.srv import Empty, EmptyResponse

from amcl.localizer import Localizer, config_from_params, map_to_odom
from amcl.sensor import beams_in_base

LOG = "amcl: "


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def set_yaw(q, yaw):
    q.x = q.y = 0.0
    q.z, q.w = math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def read_config():
    """Every filter parameter from ~ with the ROS defaults (ValueError names a bad one)."""
    return config_from_params(lambda name, default: rospy.get_param("~" + name, default))


class AmclNode:
    """One amcl instance: parameters, the localizer, and its ROS connections."""

    def __init__(self, rng=None):
        g = rospy.get_param
        self.config = read_config()
        self.transform_tolerance = rospy.Duration(float(g("~transform_tolerance", 0.1)))
        self.init_mean = np.array([float(g("~initial_pose_x", 0.0)), float(g("~initial_pose_y", 0.0)),
                                   float(g("~initial_pose_a", 0.0))])
        self.init_cov = np.diag([float(g("~initial_cov_xx", 0.25)), float(g("~initial_cov_yy", 0.25)),
                                 float(g("~initial_cov_aa", (math.pi / 12.0) ** 2))])
        if not (np.isfinite(self.init_mean).all() and np.isfinite(self.init_cov).all() and (self.init_cov >= 0).all()):
            raise ValueError("initial_pose_* must be finite and initial_cov_* finite and >= 0")
        g("~gui_publish_rate", -1.0)  # read like ROS noetic, which declares it but publishes every update
        save_rate = float(g("~save_pose_rate", 0.5))
        self.save_period = rospy.Duration(1.0 / save_rate) if save_rate > 0 else None
        self.use_map_topic = bool(g("~use_map_topic", False))
        self.first_map_only = bool(g("~first_map_only", False))
        self.odom_frame = str(g("~odom_frame_id", "odom")).lstrip("/")
        self.base_frame = str(g("~base_frame_id", "base_link")).lstrip("/")
        self.global_frame = str(g("~global_frame_id", "map")).lstrip("/")
        self.tf_broadcast = bool(g("~tf_broadcast", True))

        self.lock = threading.RLock()
        self.localizer = Localizer(self.config, rng)
        self.have_map = False
        self.laser_geometry = {}  # laser frame -> (laser_xy, rotation quaternion)
        self.last_map_to_odom = None
        self.last_save = None
        self.force_publish = True  # publish the first estimate after a (re)initialisation

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.tf_pub = tf2_ros.TransformBroadcaster()
        self.pose_pub = rospy.Publisher("amcl_pose", PoseWithCovarianceStamped, queue_size=2, latch=True)
        self.cloud_pub = rospy.Publisher("particlecloud", PoseArray, queue_size=2, latch=True)
        self.duration_pub = rospy.Publisher("~update_duration", Float64, queue_size=10)
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
        tr, q = t.transform.translation, t.transform.rotation
        return np.array([tr.x, tr.y, yaw_of(q)]), t

    def laser_pose(self, frame):
        if frame not in self.laser_geometry:
            t = self.tf_buffer.lookup_transform(self.base_frame, frame, rospy.Time(0), rospy.Duration(1.0))
            tr, q = t.transform.translation, t.transform.rotation
            self.laser_geometry[frame] = ((tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w))
        return self.laser_geometry[frame]

    def on_scan(self, scan):
        frame = scan.header.frame_id.lstrip("/")
        try:
            translation, quaternion = self.laser_pose(frame)
            odom_pose, _ = self.lookup_2d(self.odom_frame, self.base_frame, scan.header.stamp)
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as exc:
            rospy.logwarn_throttle(5.0, LOG + f"skipping a scan: no transform ({exc})")
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
                self.duration_pub.publish(Float64(elapsed))
                self.publish_cloud(scan.header.stamp)
                if result.resampled or self.force_publish:
                    self.force_publish = False
                    self.publish_pose(result, scan.header.stamp)
                    self.last_map_to_odom = map_to_odom(result.pose, odom_pose)
            elif result.reason not in ("", "not moved enough"):
                rospy.logwarn_throttle(5.0, LOG + f"skipping a scan: {result.reason}")
            if self.last_map_to_odom is not None and self.tf_broadcast:
                self.publish_tf(self.last_map_to_odom, scan.header.stamp + self.transform_tolerance)
            if self.localizer.last_estimate is not None:
                self.maybe_save_pose(*self.localizer.last_estimate)

    def publish_pose(self, result, stamp):
        msg = PoseWithCovarianceStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.global_frame
        p = msg.pose.pose
        p.position.x, p.position.y = float(result.pose[0]), float(result.pose[1])
        set_yaw(p.orientation, float(result.pose[2]))
        cov = [0.0] * 36
        cov[0], cov[1], cov[6], cov[7] = (float(v) for v in result.cov[:2, :2].ravel())
        cov[35] = float(result.cov[2, 2])
        msg.pose.covariance = cov
        self.pose_pub.publish(msg)

    def publish_cloud(self, stamp):
        msg = PoseArray()
        msg.header.stamp, msg.header.frame_id = stamp, self.global_frame
        for x, y, a in self.localizer.pf.particles:
            pose = Pose()
            pose.position.x, pose.position.y = float(x), float(y)
            set_yaw(pose.orientation, float(a))
            msg.poses.append(pose)
        self.cloud_pub.publish(msg)

    def publish_tf(self, transform, stamp):
        t = TransformStamped()
        t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, self.global_frame, self.odom_frame
        t.transform.translation.x, t.transform.translation.y = float(transform[0]), float(transform[1])
        set_yaw(t.transform.rotation, float(transform[2]))
        self.tf_pub.sendTransform(t)

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


def main():
    rospy.init_node("amcl")
    try:
        AmclNode()
    except ValueError as exc:
        rospy.logfatal(LOG + str(exc))
        raise SystemExit(1) from None
    rospy.spin()
