"""costmap_2d's Costmap2DROS in Python: parameters, sensor and map subscriptions, tf, the update
thread and the costmap publisher around a :class:`move_base.layers.LayeredCostmap`.

ROS Parameters (all in ``~<name>/``, read once, ROS defaults; pre-Hydro flat layout):
    global_frame (str, "/map"): frame of the grid (a leading '/' is dropped: tf2 refuses it).
    robot_base_frame (str, "base_link"): the robot's frame.
    transform_tolerance (float, 0.3, s): oldest robot pose accepted.
    update_frequency (float, 5.0, Hz): update-loop rate (0: no loop, ``update_now`` only).
    publish_frequency (float, 0.0, Hz): rate of ``~<name>/costmap`` (0: never).
    static_map (bool, true): use the map on ``map_topic`` (a global costmap takes its geometry; a
        rolling window in another frame places the map through tf at each update).
    rolling_window (bool, false): the grid follows the robot.
    width, height (float, 10.0, m), resolution (float, 0.05, m), origin_x, origin_y (float, 0.0, m).
    map_topic (str, "map"): the static map's topic.
    track_unknown_space (bool, false): keep unknown cells NO_INFORMATION.
    lethal_cost_threshold (int, 100): map value from which a cell is lethal.
    obstacle_range (float, 2.5, m), raytrace_range (float, 3.0, m), max_obstacle_height (float, 2.0, m):
        defaults of the observation sources.
    footprint (list of [x, y] or its string, m), robot_radius (float, 0.46, m) when there is none,
    footprint_padding (float, 0.01, m).
    inflation_radius (float, 0.55, m), cost_scaling_factor (float, 10.0, 1/m).
    observation_sources (str, ""): space-separated source names; each ``<source>`` a dict with
        topic (source name), sensor_frame (""; the message's frame), data_type ("PointCloud";
        LaserScan | PointCloud | PointCloud2), marking (true), clearing (false),
        observation_persistence (0.0, s), expected_update_rate (0.0, s),
        min_obstacle_height (0.0, m), max_obstacle_height, obstacle_range, raytrace_range (the
        costmap's), inf_is_valid (false).

ROS Publishers:
    ~<name>/costmap (nav_msgs/OccupancyGrid, latched): the costs translated as costmap_2d's
        publisher does (0 -> 0, 1..252 -> 1..98, 253 -> 99, 254 -> 100, 255 -> -1).
    ~<name>/footprint (geometry_msgs/PolygonStamped): the padded footprint at the robot, each update.

ROS Subscribers:
    <map_topic> (nav_msgs/OccupancyGrid) when static_map; each source's topic
    (sensor_msgs/LaserScan, PointCloud or PointCloud2).

LaserScan beams: a reading in [range_min, range_max) is a return (marks and clears); a reading
at or over range_max, or +inf when inf_is_valid, is a ray with no return (clears raytrace_range,
marks nothing); NaN, -inf, below range_min (and +inf without inf_is_valid) are dropped, as
laser_geometry drops them.
"""

import logging
import math
import threading

import numpy as np

from move_base.footprint import circumscribed_radius, pad_footprint, parse_footprint, transform_footprint
from move_base.layers import LayeredCostmap, ObservationSource

log = logging.getLogger(__name__)

DATA_TYPES = ("LaserScan", "PointCloud", "PointCloud2")


def cost_translation_table():
    """costmap_2d_publisher's table from costs (0..255) to OccupancyGrid values (int8)."""
    table = np.zeros(256, dtype=np.int8)
    i = np.arange(1, 253)
    table[1:253] = 1 + (97 * (i - 1)) // 251
    table[253] = 99
    table[254] = 100
    table[255] = -1
    return table


_TABLE = cost_translation_table()


def yaw_of(q):
    """Yaw [rad] of a geometry_msgs/Quaternion (its rotation about z)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def pose_to_xyyaw(transform_stamped):
    """(x [m], y [m], yaw [rad]) of a geometry_msgs/TransformStamped."""
    t = transform_stamped.transform
    return t.translation.x, t.translation.y, yaw_of(t.rotation)


def strip_slash(frame):
    return frame.lstrip("/") if frame else frame


def quaternion_matrix(x, y, z, w):
    """3x3 rotation matrix of a unit quaternion."""
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def scan_to_points(ranges, angle_min, angle_increment, range_min, range_max, raytrace_range, inf_is_valid=False):
    """Split a LaserScan (sensor frame) into returns and no-return ray ends, (N, 3) and (M, 3) [m].

    No-return rays end at ``raytrace_range`` along the beam (any point on the beam would do:
    the obstacle layer scales them to its raytrace_range)."""
    r = np.asarray(ranges, dtype=float)
    a = angle_min + np.arange(len(r)) * angle_increment
    c, s = np.cos(a), np.sin(a)
    finite = np.isfinite(r)
    ret = finite & (r >= range_min) & (r < range_max)
    free = (finite & (r >= range_max)) | (bool(inf_is_valid) & np.isposinf(r))
    points = np.column_stack([r[ret] * c[ret], r[ret] * s[ret], np.zeros(int(ret.sum()))])
    length = max(float(raytrace_range), 1e-3)
    free_ends = np.column_stack([length * c[free], length * s[free], np.zeros(int(free.sum()))])
    return points, free_ends


class Costmap2DROS:
    """One costmap (global or local) of move_base: see the module docstring for its interface.

    ``lock`` guards ``costmap`` / ``layered``; the methods below take it themselves, so do not
    call them while holding it.
    """

    def __init__(self, name, tf_buffer):
        import rospy
        from geometry_msgs.msg import PolygonStamped
        from nav_msgs.msg import OccupancyGrid

        self._rospy = rospy
        self.name = name
        self.tf_buffer = tf_buffer
        self.lock = threading.Lock()
        ns = f"~{name}/"

        def param(key, default):
            return rospy.get_param(ns + key, default)

        self.global_frame = strip_slash(str(param("global_frame", "/map")))
        self.base_frame = strip_slash(str(param("robot_base_frame", "base_link")))
        self.transform_tolerance = float(param("transform_tolerance", 0.3))
        self.update_frequency = float(param("update_frequency", 5.0))
        self.publish_frequency = float(param("publish_frequency", 0.0))
        self.static_map = bool(param("static_map", True))
        self.rolling_window = bool(param("rolling_window", False))
        width = float(param("width", 10.0))
        height = float(param("height", 10.0))
        resolution = float(param("resolution", 0.05))
        origin_x = float(param("origin_x", 0.0))
        origin_y = float(param("origin_y", 0.0))
        self.map_topic = str(param("map_topic", "map"))
        track_unknown = bool(param("track_unknown_space", False))
        lethal = int(param("lethal_cost_threshold", 100))
        obstacle_range = float(param("obstacle_range", 2.5))
        raytrace_range = float(param("raytrace_range", 3.0))
        max_obstacle_height = float(param("max_obstacle_height", 2.0))
        robot_radius = float(param("robot_radius", 0.46))
        padding = float(param("footprint_padding", 0.01))
        inflation_radius = float(param("inflation_radius", 0.55))
        cost_scaling_factor = float(param("cost_scaling_factor", 10.0))
        checks = [
            ("transform_tolerance", self.transform_tolerance >= 0.0),
            ("update_frequency", self.update_frequency >= 0.0),
            ("publish_frequency", self.publish_frequency >= 0.0),
            ("width", width > 0.0),
            ("height", height > 0.0),
            ("resolution", resolution > 0.0),
            ("lethal_cost_threshold", 0 < lethal <= 100),
            ("obstacle_range", obstacle_range >= 0.0),
            ("raytrace_range", raytrace_range >= 0.0),
            ("robot_radius", robot_radius > 0.0),
            ("footprint_padding", padding >= 0.0),
            ("inflation_radius", inflation_radius >= 0.0),
            ("cost_scaling_factor", cost_scaling_factor >= 0.0),
        ]
        for key, ok in checks:
            if not ok:
                raise ValueError(f"{name}: parameter {ns}{key} = {param(key, None)!r} is out of range")
        if not self.global_frame or not self.base_frame:
            raise ValueError(f"{name}: parameters {ns}global_frame and {ns}robot_base_frame must not be empty")
        try:
            footprint = parse_footprint(param("footprint", None), robot_radius)
        except ValueError as exc:
            raise ValueError(f"{name}: parameter {ns}footprint: {exc}") from None
        self.footprint = pad_footprint(footprint, padding)

        self.sources = []
        self._source_cfg = {}
        for source in str(param("observation_sources", "")).split():
            cfg = param(source, {})
            if not isinstance(cfg, dict):
                raise ValueError(f"{name}: parameter {ns}{source} must be a dictionary, got {cfg!r}")
            data_type = str(cfg.get("data_type", "PointCloud"))
            if data_type not in DATA_TYPES:
                raise ValueError(f"{name}: parameter {ns}{source}/data_type {data_type!r} is not one of {DATA_TYPES}")
            src = ObservationSource(
                name=source,
                obstacle_range=float(cfg.get("obstacle_range", obstacle_range)),
                raytrace_range=float(cfg.get("raytrace_range", raytrace_range)),
                min_obstacle_height=float(cfg.get("min_obstacle_height", 0.0)),
                max_obstacle_height=float(cfg.get("max_obstacle_height", max_obstacle_height)),
                marking=bool(cfg.get("marking", True)),
                clearing=bool(cfg.get("clearing", False)),
                observation_persistence=float(cfg.get("observation_persistence", 0.0)),
                expected_update_rate=float(cfg.get("expected_update_rate", 0.0)),
            )
            for key in ("obstacle_range", "raytrace_range", "observation_persistence", "expected_update_rate"):
                if getattr(src, key) < 0.0:
                    raise ValueError(f"{name}: parameter {ns}{source}/{key} must not be negative")
            self.sources.append(src)
            self._source_cfg[source] = {
                "topic": str(cfg.get("topic", source)),
                "sensor_frame": strip_slash(str(cfg.get("sensor_frame", ""))),
                "data_type": data_type,
                "inf_is_valid": bool(cfg.get("inf_is_valid", False)),
            }

        size_x = max(1, int(width / resolution))
        size_y = max(1, int(height / resolution))
        self.layered = LayeredCostmap(
            size_x,
            size_y,
            resolution,
            origin_x,
            origin_y,
            footprint=self.footprint,
            rolling_window=self.rolling_window,
            track_unknown_space=track_unknown,
            static_map=self.static_map,
            sources=self.sources,
            inflation_radius=inflation_radius,
            cost_scaling_factor=cost_scaling_factor,
            lethal_cost_threshold=lethal,
            now=rospy.get_time(),
        )
        self.inscribed_radius = self.layered.inscribed_radius
        self.circumscribed_radius = circumscribed_radius(self.footprint)

        self._running = False  # updates paused until start()
        self._quit = threading.Event()
        self._thread = None
        self._last_publish = -math.inf
        self._last_pose_warning = -math.inf

        # publishers before subscribers
        self.costmap_pub = rospy.Publisher(ns + "costmap", OccupancyGrid, queue_size=1, latch=True)
        self.footprint_pub = rospy.Publisher(ns + "footprint", PolygonStamped, queue_size=1)
        self._subscribers = []
        if self.static_map:
            self._subscribers.append(rospy.Subscriber(self.map_topic, OccupancyGrid, self._map_cb, queue_size=1))
        for src in self.sources:
            cfg = self._source_cfg[src.name]
            if cfg["data_type"] == "LaserScan":
                from sensor_msgs.msg import LaserScan as msg_class
            elif cfg["data_type"] == "PointCloud":
                from sensor_msgs.msg import PointCloud as msg_class
            else:
                from sensor_msgs.msg import PointCloud2 as msg_class
            self._subscribers.append(
                rospy.Subscriber(cfg["topic"], msg_class, self._sensor_cb, callback_args=src.name, queue_size=1)
            )
        rospy.loginfo(
            "%s: %s costmap in %s, %d x %d cells at %.3f m, sources: %s",
            name,
            "rolling" if self.rolling_window else "static" if self.static_map else "fixed",
            self.global_frame,
            size_x,
            size_y,
            resolution,
            " ".join(s.name for s in self.sources) or "none",
        )

    # --- properties ----------------------------------------------------------------------------
    @property
    def costmap(self):
        """The master Costmap2D (read it under ``lock``)."""
        return self.layered.costmap

    # --- life cycle ----------------------------------------------------------------------------
    def start(self):
        """Start (or resume) the updates: the update thread runs at update_frequency."""
        now = self._rospy.get_time()
        with self.lock:
            for b in self.layered.obstacles.buffers.values():
                b.reset_last_updated(now)
            self._running = True
        if self._thread is None and self.update_frequency > 0.0:
            self._thread = threading.Thread(target=self._loop, name=f"{self.name}_update", daemon=True)
            self._thread.start()

    def stop(self):
        """Pause the updates and ignore sensor data (move_base's shutdown_costmaps)."""
        with self.lock:
            self._running = False

    def shutdown(self):
        """End the update thread, the subscriptions and the publishers."""
        self._running = False
        self._quit.set()
        for handle in [*self._subscribers, self.costmap_pub, self.footprint_pub]:
            handle.unregister()
        self._subscribers = []
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)

    def _loop(self):
        rospy = self._rospy
        rate = rospy.Rate(self.update_frequency)
        while not self._quit.is_set() and not rospy.is_shutdown():
            if self._running:
                try:
                    self.update_now()
                except Exception:  # noqa: BLE001 - the loop must survive one bad cycle
                    rospy.logerr("%s: costmap update failed", self.name, exc_info=True)
            try:
                rate.sleep()
            except rospy.ROSTimeMovedBackwardsException:
                continue
            except rospy.ROSInterruptException:
                break

    # --- robot pose ----------------------------------------------------------------------------
    def get_robot_pose(self):
        """(x [m], y [m], yaw [rad]) of robot_base_frame in global_frame, or None (no transform,
        or older than transform_tolerance; a throttled warning says which)."""
        import tf2_ros

        rospy = self._rospy
        try:
            tf = self.tf_buffer.lookup_transform(self.global_frame, self.base_frame, rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as exc:
            self._warn_pose(f"no transform from {self.base_frame} to {self.global_frame}: {exc}")
            return None
        stamp = tf.header.stamp.to_sec()
        age = rospy.get_time() - stamp
        if stamp > 0.0 and age > self.transform_tolerance:
            self._warn_pose(
                f"transform from {self.base_frame} to {self.global_frame} is {age:.3f} s old "
                f"(transform_tolerance {self.transform_tolerance:.3f} s)"
            )
            return None
        return pose_to_xyyaw(tf)

    def _map_pose(self, frame):
        """(x [m], y [m], yaw [rad]) of the static map's ``frame`` in global_frame, the newest
        tf has, or None (a throttled warning; the map stays where it last was)."""
        import tf2_ros

        try:
            tf = self.tf_buffer.lookup_transform(self.global_frame, frame, self._rospy.Time(0))
        except tf2_ros.TransformException as exc:
            self._rospy.logwarn_throttle(
                5.0, f"{self.name}: the static map stays put: no transform {frame} -> {self.global_frame}: {exc}"
            )
            return None
        return pose_to_xyyaw(tf)

    def _warn_pose(self, text):
        now = self._rospy.get_time()
        if now - self._last_pose_warning >= 1.0 or now < self._last_pose_warning:
            self._last_pose_warning = now
            self._rospy.logwarn("%s: %s", self.name, text)

    # --- updates -------------------------------------------------------------------------------
    def update_now(self):
        """One synchronous update at the robot's pose; publishes the footprint, and the costmap
        when publish_frequency > 0 and its period has passed. False when there is no pose."""
        pose = self.get_robot_pose()
        if pose is None:
            return False
        x, y, yaw = pose
        static = self.layered.static
        map_pose = self._map_pose(static.frame_id) if static is not None and static.needs_pose else None
        with self.lock:
            if map_pose is not None:
                self.layered.set_static_pose(map_pose)
            self.layered.update(x, y, yaw)
        self._publish_footprint(x, y, yaw)
        if self.publish_frequency > 0.0:
            now = self._rospy.get_time()
            if now - self._last_publish >= 1.0 / self.publish_frequency or now < self._last_publish:
                self._last_publish = now
                self.publish_costmap()
        return True

    def publish_costmap(self):
        """Publish the master grid on ~<name>/costmap."""
        from nav_msgs.msg import OccupancyGrid

        msg = OccupancyGrid()
        msg.header.frame_id = self.global_frame
        msg.header.stamp = self._rospy.Time.now()
        with self.lock:
            c = self.layered.costmap
            msg.info.resolution = c.resolution
            msg.info.width = c.size_x
            msg.info.height = c.size_y
            msg.info.origin.position.x = c.origin_x
            msg.info.origin.position.y = c.origin_y
            data = _TABLE[c.costs].ravel()
        msg.info.origin.orientation.w = 1.0
        msg.info.map_load_time = msg.header.stamp
        msg.data = data.tolist()
        self.costmap_pub.publish(msg)

    def _publish_footprint(self, x, y, yaw):
        from geometry_msgs.msg import Point32, PolygonStamped

        msg = PolygonStamped()
        msg.header.frame_id = self.global_frame
        msg.header.stamp = self._rospy.Time.now()
        msg.polygon.points = [Point32(px, py, 0.0) for px, py in transform_footprint(self.footprint, x, y, yaw)]
        self.footprint_pub.publish(msg)

    # --- callbacks -----------------------------------------------------------------------------
    def _map_cb(self, msg):
        rospy = self._rospy
        frame = strip_slash(msg.header.frame_id)
        q = msg.info.origin.orientation
        if abs(2.0 * (q.w * q.z + q.x * q.y)) > 1e-6:
            rospy.logwarn("%s: the map's origin is rotated; the rotation is ignored", self.name)
        other_frame = bool(frame) and frame != self.global_frame
        needs_pose = other_frame and self.rolling_window  # placed through tf at each update
        if other_frame and not self.rolling_window:
            rospy.logwarn(
                "%s: the map is in frame %s, the costmap in %s; it is used as if in %s",
                self.name,
                frame,
                self.global_frame,
                self.global_frame,
            )
        data = np.frombuffer(msg.data, dtype=np.int8) if isinstance(msg.data, bytes) else np.asarray(msg.data)
        with self.lock:
            self.layered.set_static_map(
                data,
                msg.info.width,
                msg.info.height,
                msg.info.resolution,
                msg.info.origin.position.x,
                msg.info.origin.position.y,
                frame,
                needs_pose,
            )
        rospy.loginfo(
            "%s: received a %d x %d map at %.3f m/cell", self.name, msg.info.width, msg.info.height, msg.info.resolution
        )

    def _transform(self, frame, stamp):
        """(R (3, 3), t (3,)) from ``frame`` to global_frame at ``stamp``, or None."""
        import tf2_ros

        rospy = self._rospy
        try:
            tf = self.tf_buffer.lookup_transform(
                self.global_frame, frame, stamp, rospy.Duration(max(self.transform_tolerance, 0.05))
            )
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as exc:
            rospy.logwarn_throttle(
                1.0, f"{self.name}: dropped a reading: no transform {frame} -> {self.global_frame}: {exc}"
            )
            return None
        except tf2_ros.TransformException as exc:
            rospy.logwarn_throttle(1.0, f"{self.name}: dropped a reading: {exc}")
            return None
        q, t = tf.transform.rotation, tf.transform.translation
        return quaternion_matrix(q.x, q.y, q.z, q.w), np.array([t.x, t.y, t.z])

    def _sensor_cb(self, msg, source_name):
        if not self._running:
            return
        cfg = self._source_cfg[source_name]
        src = self.layered.obstacles.buffers[source_name].source
        frame = strip_slash(msg.header.frame_id)
        if cfg["data_type"] == "LaserScan":
            points, free_ends = scan_to_points(
                msg.ranges,
                msg.angle_min,
                msg.angle_increment,
                msg.range_min,
                msg.range_max,
                src.raytrace_range,
                cfg["inf_is_valid"],
            )
        elif cfg["data_type"] == "PointCloud":
            points = np.array([(p.x, p.y, p.z) for p in msg.points], dtype=float).reshape(-1, 3)
            free_ends = None
        else:
            from sensor_msgs import point_cloud2

            points = np.array(
                list(point_cloud2.read_points(msg, field_names=("x", "y", "z"), skip_nans=True)), dtype=float
            ).reshape(-1, 3)
            free_ends = None
        tf = self._transform(frame, msg.header.stamp)
        if tf is None:
            return
        rot, trans = tf
        origin = trans
        sensor_frame = cfg["sensor_frame"]
        if sensor_frame and sensor_frame != frame:
            tf_origin = self._transform(sensor_frame, msg.header.stamp)
            if tf_origin is None:
                return
            origin = tf_origin[1]
        points = points @ rot.T + trans
        if free_ends is not None:
            free_ends = free_ends @ rot.T + trans
        now = self._rospy.get_time()
        with self.lock:
            self.layered.obstacles.add_observation(
                source_name, origin, points, free_ends, stamp=msg.header.stamp.to_sec(), now=now
            )

    # --- queries and recoveries ----------------------------------------------------------------
    def is_current(self):
        """False when a source with an expected_update_rate has not reported in time."""
        with self.lock:
            return self.layered.obstacles.is_current(self._rospy.get_time())

    def stale_sources(self):
        with self.lock:
            return self.layered.obstacles.stale_sources(self._rospy.get_time())

    def has_map(self):
        with self.lock:
            return self.layered.has_map()

    def reset_layers(self):
        with self.lock:
            self.layered.reset_layers(self._rospy.get_time())

    def clear_outside(self, x, y, size):
        with self.lock:
            self.layered.clear_outside(x, y, size)

    def clear_unknown_around(self, x, y, size):
        with self.lock:
            self.layered.clear_unknown_around(x, y, size)

    def footprint_cost(self, x, y, yaw):
        with self.lock:
            return self.layered.footprint_cost(x, y, yaw)
