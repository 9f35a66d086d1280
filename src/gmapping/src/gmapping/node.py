"""slam_gmapping node: the ROS interface of slam_gmapping around :class:`gmapping.slam.GridSlam`.

ROS Parameters: gmapping.params.SLAM and NODE, slam_gmapping's names and defaults (rendered in the README).

ROS Subscribers:
    scan (sensor_msgs/LaserScan): the laser; its frame's pose on the robot comes from tf.
    tf: odom_frame -> base_frame at each scan's time, base_frame -> the scan's frame.

ROS Publishers:
    map (nav_msgs/OccupancyGrid, latched), map_metadata (nav_msgs/MapMetaData, latched): the best
        particle's map, after the first processed scan and then every map_update_interval.
    ~entropy (std_msgs/Float64): entropy of the particles' weights after every processed scan.
    tf: map_frame -> odom_frame, every transform_publish_period, stamped now + tf_delay.
    /diagnostics: scans processed and skipped (with the reasons), the filter, the map.

ROS Services:
    dynamic_map (nav_msgs/GetMap): the map as of now (built from the best particle when called).
"""

import threading
import time

import numpy as np
import rospy
import tf2_ros
from nav_msgs.msg import MapMetaData, OccupancyGrid
from nav_msgs.srv import GetMap, GetMapResponse
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64

from florence_common.pose import from_matrix, yaw_to_quaternion
from florence_common_ros.convert import transform_stamped
from florence_common_ros.diagnostics import ERROR, OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from florence_common_ros.transforms import lookup_matrix
from gmapping.laser import LaserGeometry, LaserNotPlanar
from gmapping.params import NODE
from gmapping.slam import GridSlam, config_from_params, warm_up

LOG = "slam_gmapping: "
ODOM_TIMEOUT = 0.5  # [s] of ROS time to wait for odometry at a scan's time (slam_gmapping's tf filter waits)


class SlamGMappingNode:
    """One slam_gmapping: parameters, the mapper (made at the first scan) and its ROS connections."""

    def __init__(self):
        self.config = config_from_params(lambda name, default: rospy.get_param("~" + name, default))
        p = read_params(NODE)
        self.p = p
        self.base_frame, self.map_frame, self.odom_frame = p.base_frame, p.map_frame, p.odom_frame
        self.map_update_interval = rospy.Duration(p.map_update_interval)
        self.tf_delay = rospy.Duration(p.transform_publish_period if p.tf_delay is None else p.tf_delay)
        self.rng = np.random.default_rng(None if p.seed < 0 else p.seed)

        self.lock = threading.Lock()  # the mapper and the map
        self.slam = None
        self.lasers = {}  # (frame, count, angle_min, angle_increment) -> LaserGeometry
        self.map_to_odom = (0.0, 0.0, 0.0)  # x, y, yaw: identity until the first processed scan
        self.tf_lock = threading.Lock()
        self.map_msg = None  # the last map built
        self.last_map_update = None
        self.scans = 0
        self.processed = 0
        self.skipped = {}  # reason -> scans skipped for it since the last diagnostics
        self.last_result = None
        self.last_update_ms = 0.0

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.tf_pub = tf2_ros.TransformBroadcaster()
        self.map_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub = rospy.Publisher("map_metadata", MapMetaData, queue_size=1, latch=True)
        self.entropy_pub = rospy.Publisher("~entropy", Float64, queue_size=1)
        self.diag = Diagnostics("slam_gmapping")
        self.diag.add("Mapping", self._diagnose)
        self.service = rospy.Service("dynamic_map", GetMap, self.on_dynamic_map)
        self._stop = threading.Event()
        self.tf_thread = None
        if p.transform_publish_period > 0:
            self.tf_thread = threading.Thread(target=self._publish_tf_loop, name="map_to_odom", daemon=True)
            self.tf_thread.start()
        took = warm_up()  # before the first scan: compiling the kernels there would leave the scans queued
        rospy.loginfo(LOG + "kernels ready in %.1f s", took)
        self.scan_sub = rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=5, buff_size=2**22)
        rospy.loginfo(LOG + "%d particles, map at %.3f m/cell; waiting for scans on %s", self.config.particles,
                      self.config.delta, rospy.resolve_name("scan"))

    def shutdown(self):
        self._stop.set()
        self.diag.shutdown()

    # ---- tf ---------------------------------------------------------------------------------------------------
    def _publish_tf_loop(self):
        rate = rospy.Rate(1.0 / self.p.transform_publish_period)
        last = None
        while not self._stop.is_set() and not rospy.is_shutdown():
            with self.tf_lock:
                x, y, yaw = self.map_to_odom
            try:
                stamp = rospy.Time.now() + self.tf_delay
                if stamp != last:  # simulated time may not have moved since the last round
                    self.tf_pub.sendTransform(transform_stamped(stamp, self.map_frame, self.odom_frame, x, y, yaw))
                    last = stamp
                rate.sleep()
            except rospy.ROSTimeMovedBackwardsException:
                rate = rospy.Rate(1.0 / self.p.transform_publish_period)
            except rospy.ROSInterruptException:
                return

    # ---- scans ------------------------------------------------------------------------------------------------
    def _skip(self, reason):
        self.skipped[reason] = self.skipped.get(reason, 0) + 1
        rospy.logwarn_throttle(5.0, LOG + f"skipping a scan: {reason}")

    def laser_geometry(self, scan):
        """The scan's LaserGeometry, from tf once per laser frame and beam layout; (None, why) if unknown."""
        frame = scan.header.frame_id.lstrip("/")
        key = (frame, len(scan.ranges), scan.angle_min, scan.angle_increment)
        if key in self.lasers:
            return self.lasers[key], None
        if not frame:
            return None, "the scan has no frame_id"
        matrix, why = lookup_matrix(self.tf_buffer, self.base_frame, frame, rospy.Time(0), 0.5)
        if matrix is None:
            return None, f"the laser frame '{frame}' is not in tf ({why})"
        try:
            laser = LaserGeometry.from_transform(matrix, scan.angle_min, scan.angle_increment, len(scan.ranges))
        except LaserNotPlanar as exc:
            return None, f"{exc} (frame '{frame}')"
        rospy.loginfo(LOG + "laser '%s' is mounted %s, %.3f m ahead and %.3f m left of %s", frame,
                      "upside down" if laser.upside_down else "upwards", laser.x, laser.y, self.base_frame)
        self.lasers[key] = laser
        return laser, None

    def on_scan(self, scan):
        self.scans += 1
        if (self.scans - 1) % self.p.throttle_scans:
            return
        if not scan.ranges:
            self._skip("an empty scan")
            return
        if not (np.isfinite([scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max]).all()
                and scan.angle_increment != 0 and scan.range_max > 0):
            self._skip(f"a scan with a bad header (angle_increment {scan.angle_increment}, range_max "
                       f"{scan.range_max})")
            return
        laser, why = self.laser_geometry(scan)
        if laser is None:
            self._skip(why)
            return
        odom, why = lookup_matrix(self.tf_buffer, self.odom_frame, self.base_frame, scan.header.stamp, ODOM_TIMEOUT)
        if odom is None:
            self._skip(f"no odometry at the scan's time: {why}")
            return
        odom_pose = from_matrix(odom)
        stamp = scan.header.stamp
        with self.lock:
            started = time.perf_counter()
            if self.slam is None:
                self.slam = GridSlam(self.config, odom_pose, self.rng)
                rospy.loginfo(LOG + "initialised at the odometry pose (%.3f, %.3f, %.3f)", *odom_pose)
            ranges = np.asarray(scan.ranges, dtype=float)
            result = self.slam.process_scan(odom_pose, laser, ranges, scan.range_min, scan.range_max, stamp.to_sec())
            if result.odometry_jump:
                rospy.logwarn(LOG + "the odometry has a big jump here")
            if not result.processed:
                return
            self.processed += 1
            self.last_result = result
            self.last_update_ms = 1e3 * (time.perf_counter() - started)
            if result.failed_matches:
                rospy.logdebug(LOG + "scan matching failed for %d particles, using odometry", result.failed_matches)
            if np.count_nonzero(np.isfinite(self.slam.scans[-1][1])) == 0:
                rospy.logwarn_throttle(5.0, LOG + "a processed scan had no usable reading (NaN, inf or out of range)")
            with self.tf_lock:
                self.map_to_odom = self.slam.map_to_odom(odom_pose)
            self.entropy_pub.publish(Float64(self.slam.entropy()))
            if self.last_map_update is None or stamp - self.last_map_update > self.map_update_interval:
                self.publish_map()
                self.last_map_update = stamp

    # ---- the map ----------------------------------------------------------------------------------------------
    def build_map_msg(self):
        """The best particle's map as an OccupancyGrid (the caller holds the lock)."""
        data, origin, resolution = self.slam.build_map()
        msg = OccupancyGrid()
        msg.header.frame_id = self.map_frame
        msg.header.stamp = rospy.Time.now()
        info = msg.info
        info.map_load_time = msg.header.stamp
        info.resolution = resolution
        info.height, info.width = data.shape
        info.origin.position.x, info.origin.position.y = origin
        q = info.origin.orientation
        q.x, q.y, q.z, q.w = yaw_to_quaternion(0.0)
        msg.data = data.ravel().tolist()
        return msg

    def publish_map(self):
        self.map_msg = self.build_map_msg()
        self.map_pub.publish(self.map_msg)
        self.meta_pub.publish(self.map_msg.info)

    def on_dynamic_map(self, _req):
        with self.lock:
            if self.slam is None:
                raise rospy.ServiceException("no map yet: no scan has been processed")
            self.map_msg = self.build_map_msg()
            return GetMapResponse(map=self.map_msg)

    # ---- diagnostics ------------------------------------------------------------------------------------------
    def _diagnose(self, stat):
        skipped, self.skipped = self.skipped, {}
        slam, result = self.slam, self.last_result
        if slam is None:
            stat.summary(ERROR if skipped else WARN, "no scan processed yet" + (
                f": {'; '.join(f'{k} ({v})' for k, v in sorted(skipped.items()))}"[:200] if skipped else ""))
        elif skipped:
            stat.summary(WARN, f"scans skipped: {'; '.join(f'{k} ({v})' for k, v in sorted(skipped.items()))}"[:200])
        else:
            stat.summary(OK, f"mapping with {slam.cfg.particles} particles")
        stat.add("scans received", self.scans)
        stat.add("scans processed", self.processed)
        if slam is not None:
            stat.add("resamplings", slam.resamplings)
            stat.add("effective sample size", f"{slam.neff:.1f}")
            stat.add("last update (ms)", f"{self.last_update_ms:.1f}")
            stat.add("best pose (x, y, yaw)", "{:.3f}, {:.3f}, {:.3f}".format(*slam.best_pose()))
            stat.add("particle maps (MiB)", f"{slam.maps.nbytes() / 2**20:.1f}")
        if result is not None:
            stat.add("beams matched (last update)", f"{100 * result.matched:.0f} %")
            stat.add("failed matches (last update)", result.failed_matches)
        if self.map_msg is not None:
            stat.add("map (cells)", f"{self.map_msg.info.width} x {self.map_msg.info.height}")
        return stat


def main():
    run(SlamGMappingNode, "slam_gmapping")
