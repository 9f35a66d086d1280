"""costmap_2d's Costmap2DROS in Python: parameters, sensor and map subscriptions, tf, the update
thread and the costmap publisher around a :class:`move_base.layers.LayeredCostmap`.

ROS Parameters (all in ``~<name>/``, read once, costmap_2d's names and defaults; pre-Hydro flat
layout): :data:`move_base.costmap_config.PARAMS`, and for each of ``observation_sources`` a
dictionary ``~<name>/<source>`` of :data:`move_base.costmap_config.SOURCE_PARAMS` (rendered in
the README).

ROS Publishers:
    ~<name>/costmap (nav_msgs/OccupancyGrid, latched): the costs translated as costmap_2d's
        publisher does (0 -> 0, 1..252 -> 1..98, 253 -> 99, 254 -> 100, 255 -> -1).
    ~<name>/footprint (geometry_msgs/PolygonStamped): the padded footprint at the robot, each update.
    ~<name>/voxel_grid (sensor_msgs/PointCloud2, x y z): the marked voxels' centres, with
        map_type voxel and publish_voxel_map, while somebody listens.

ROS Subscribers:
    <map_topic> (nav_msgs/OccupancyGrid) when static_map; each source's topic
    (sensor_msgs/LaserScan, PointCloud or PointCloud2); <keepout_map_topic>
    (nav_msgs/OccupancyGrid) and <people_topic> (user_tracker_ni/TrackedUsers) when set.

Sensor messages are only queued by their callbacks; each update converts the newest of each
source (all of them within observation_persistence), so a 15 Hz point cloud costs its conversion
at the update rate only. Bad input is skipped with a throttled warning that names it: a cloud
without float32 x, y, z or with too little data, a reading without a transform to the costmap's
frame; NaN and inf points are no readings. A keep-out map of another size, resolution or origin
than the map is placed by its own origin and resolution (a warning says so). People at a NaN or
infinite position are left out; a people message without positions (the seed's three fields
only) adds nobody.

LaserScan beams: a reading in [range_min, range_max) is a return (marks and clears); a reading
at or over range_max, or +inf when inf_is_valid, is a ray with no return (clears raytrace_range,
marks nothing); NaN, -inf, below range_min (and +inf without inf_is_valid) are dropped, as
laser_geometry drops them.
"""

import logging
import math
import threading

import numpy as np

from florence_common.params import ParamError
from florence_common_ros import convert
from move_base.costmap_config import CostmapConfig
from move_base.footprint import circumscribed_radius, transform_footprint

log = logging.getLogger(__name__)


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


def strip_slash(frame):
    return frame.lstrip("/") if frame else frame


def _turns_the_map(q):
    """Whether a map's origin orientation turns it (a zero quaternion, an unset field, does not)."""
    return any((q.x, q.y, q.z, q.w)) and abs(convert.yaw_of(q)) > 1e-6


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
        try:
            cfg = CostmapConfig.read(lambda key, default: rospy.get_param(ns + key, default))
        except ParamError as exc:
            raise ParamError(f"{name} ({ns}): {exc}") from None
        p = self.params = cfg.params
        self.global_frame = p.global_frame
        self.base_frame = p.robot_base_frame
        self.transform_tolerance = p.transform_tolerance
        self.robot_pose_age = 0.0  # [s] of the last pose get_robot_pose returned
        self.update_frequency = p.update_frequency
        self.publish_frequency = p.publish_frequency
        self.static_map = p.static_map
        self.rolling_window = p.rolling_window
        self.map_topic = p.map_topic
        self.footprint = cfg.footprint
        self.body = cfg.body  # the footprint without its padding
        self.sources = list(cfg.sources)
        self._inputs = cfg.inputs
        size_x, size_y = cfg.size
        self.layered = cfg.layered(now=rospy.get_time())
        self.inscribed_radius = self.layered.inscribed_radius
        self.circumscribed_radius = circumscribed_radius(self.footprint)

        self._running = False  # updates paused until start()
        self._quit = threading.Event()
        self._thread = None
        self._last_publish = -math.inf
        self._last_pose_warning = -math.inf
        self.last_update = None  # [s] ROS time of the last update at the robot's pose

        self._pending = {}  # source name -> [(message, arrival time [s])], handled by the next update
        self._pending_lock = threading.Lock()
        self._warned = {}  # kind -> ROS time [s] of its last warning (throttled per kind)

        # publishers before subscribers
        self.costmap_pub = rospy.Publisher(ns + "costmap", OccupancyGrid, queue_size=1, latch=True)
        self.footprint_pub = rospy.Publisher(ns + "footprint", PolygonStamped, queue_size=1)
        self.voxel_pub = None
        if p.map_type == "voxel" and p.publish_voxel_map:
            from sensor_msgs.msg import PointCloud2

            self.voxel_pub = rospy.Publisher(ns + "voxel_grid", PointCloud2, queue_size=1)
        self._subscribers = []
        if self.static_map:
            self._subscribers.append(rospy.Subscriber(self.map_topic, OccupancyGrid, self._map_cb, queue_size=1))
        if p.keepout_map_topic:
            self._subscribers.append(rospy.Subscriber(p.keepout_map_topic, OccupancyGrid, self._keepout_cb,
                                                      queue_size=1))
        if p.people_topic:
            from user_tracker_ni.msg import TrackedUsers

            self._subscribers.append(rospy.Subscriber(p.people_topic, TrackedUsers, self._people_cb, queue_size=1))
        for src in self.sources:
            source = self._inputs[src.name]
            if source.data_type == "LaserScan":
                from sensor_msgs.msg import LaserScan as msg_class
            elif source.data_type == "PointCloud":
                from sensor_msgs.msg import PointCloud as msg_class
            else:
                from sensor_msgs.msg import PointCloud2 as msg_class
            self._subscribers.append(
                rospy.Subscriber(source.topic, msg_class, self._sensor_cb, callback_args=src.name, queue_size=1)
            )
        rospy.loginfo(
            "%s: %s costmap in %s, %d x %d cells at %.3f m, %s obstacles, sources: %s%s%s",
            name,
            "rolling" if self.rolling_window else "static" if self.static_map else "fixed",
            self.global_frame,
            size_x,
            size_y,
            p.resolution,
            "voxel" if p.map_type == "voxel" else "2-D",
            " ".join(s.name for s in self.sources) or "none",
            f", keep-out map {p.keepout_map_topic}" if p.keepout_map_topic else "",
            f", people from {p.people_topic}" if p.people_topic else "",
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
        for handle in [*self._subscribers, self.costmap_pub, self.footprint_pub, *filter(None, [self.voxel_pub])]:
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
        or older than transform_tolerance; a throttled warning says which). ``robot_pose_age``: how
        old [s] the transform of the last pose returned was."""
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
        self.robot_pose_age = max(0.0, age) if stamp > 0.0 else 0.0
        return convert.to_xyyaw(tf)

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
        return convert.to_xyyaw(tf)

    def _warn(self, kind, text, period=5.0):
        """A warning at most every ``period`` [s] of ROS time per ``kind`` (rospy's throttle is per
        call site: one kind of bad input would silence the others)."""
        now = self._rospy.get_time()
        last = self._warned.get(kind)
        if last is None or now - last >= period or now < last:
            self._warned[kind] = now
            self._rospy.logwarn("%s: %s", self.name, text)

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
        self._take_pending()
        static, keepout = self.layered.static, self.layered.keepout
        map_pose = self._map_pose(static.frame_id) if static is not None and static.needs_pose else None
        keepout_pose = self._map_pose(keepout.frame_id) if keepout is not None and keepout.needs_pose else None
        now = self._rospy.get_time()
        with self.lock:
            if map_pose is not None:
                self.layered.set_static_pose(map_pose)
            if keepout_pose is not None:
                self.layered.set_keepout_pose(keepout_pose)
            self.layered.update(x, y, yaw, now)
        self.last_update = now
        self._publish_footprint(x, y, yaw)
        if self.voxel_pub is not None and self.voxel_pub.get_num_connections():
            self._publish_voxels()
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

    def _publish_voxels(self):
        from sensor_msgs import point_cloud2
        from std_msgs.msg import Header

        with self.lock:
            centres = self.layered.obstacles.voxel_centres()
        header = Header(frame_id=self.global_frame, stamp=self._rospy.Time.now())
        self.voxel_pub.publish(point_cloud2.create_cloud_xyz32(header, centres.astype(np.float32).tolist()))

    def _publish_footprint(self, x, y, yaw):
        from geometry_msgs.msg import Point32, PolygonStamped

        msg = PolygonStamped()
        msg.header.frame_id = self.global_frame
        msg.header.stamp = self._rospy.Time.now()
        msg.polygon.points = [Point32(px, py, 0.0) for px, py in transform_footprint(self.footprint, x, y, yaw)]
        self.footprint_pub.publish(msg)

    # --- callbacks -----------------------------------------------------------------------------
    def _grid_of(self, msg, what):
        """(data int8 array, frame, needs_pose) of an OccupancyGrid for the layers."""
        rospy = self._rospy
        frame = strip_slash(msg.header.frame_id)
        if _turns_the_map(msg.info.origin.orientation):
            rospy.logwarn("%s: the %s's origin is rotated; the rotation is ignored", self.name, what)
        other_frame = bool(frame) and frame != self.global_frame
        needs_pose = other_frame and self.rolling_window  # placed through tf at each update
        if other_frame and not self.rolling_window:
            rospy.logwarn(
                "%s: the %s is in frame %s, the costmap in %s; it is used as if in %s",
                self.name,
                what,
                frame,
                self.global_frame,
                self.global_frame,
            )
        data = np.frombuffer(msg.data, dtype=np.int8) if isinstance(msg.data, bytes) else np.asarray(msg.data)
        return data, frame, needs_pose

    def _grid_problem(self, msg):
        """Why an OccupancyGrid cannot be used, or ''."""
        info = msg.info
        if info.width <= 0 or info.height <= 0:
            return f"it has no cells ({info.width} x {info.height})"
        if not (math.isfinite(info.resolution) and info.resolution > 0.0):
            return f"its resolution {info.resolution} is not a positive number"
        if not (math.isfinite(info.origin.position.x) and math.isfinite(info.origin.position.y)):
            return "its origin is not finite"
        if len(msg.data) != info.width * info.height:
            return f"it has {len(msg.data)} values for {info.width} x {info.height} cells"
        return ""

    def _map_cb(self, msg):
        rospy = self._rospy
        problem = self._grid_problem(msg)
        if problem:
            self._warn("map", f"map on {self.map_topic} ignored: {problem}")
            return
        data, frame, needs_pose = self._grid_of(msg, "map")
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
            matches = self.layered.keepout_matches_map()
        rospy.loginfo(
            "%s: received a %d x %d map at %.3f m/cell", self.name, msg.info.width, msg.info.height, msg.info.resolution
        )
        self._check_keepout(matches)

    def _keepout_cb(self, msg):
        rospy = self._rospy
        topic = self.params.keepout_map_topic
        problem = self._grid_problem(msg)
        if problem:
            self._warn("keepout", f"keep-out map on {topic} ignored: {problem}")
            return
        data, frame, needs_pose = self._grid_of(msg, "keep-out map")
        with self.lock:
            matches = self.layered.set_keepout_map(data, msg.info.width, msg.info.height, msg.info.resolution,
                                                   msg.info.origin.position.x, msg.info.origin.position.y, frame,
                                                   needs_pose)
        rospy.loginfo("%s: received a %d x %d keep-out map at %.3f m/cell from %s: %d cells kept out", self.name,
                      msg.info.width, msg.info.height, msg.info.resolution, topic,
                      int(np.count_nonzero(data.view(np.uint8) >= self.params.lethal_cost_threshold)))
        self._check_keepout(matches)

    def _check_keepout(self, matches):
        if matches is False:
            k = self.layered.keepout.grid
            ref = self.layered.static.grid if self.layered.static is not None else self.layered.costmap
            self._warn("keepout_geometry",
                       f"the keep-out map ({k.size_x} x {k.size_y} cells at {k.resolution:.3f} m from "
                       f"({k.origin_x:.2f}, {k.origin_y:.2f})) differs from the map ({ref.size_x} x {ref.size_y} at "
                       f"{ref.resolution:.3f} m from ({ref.origin_x:.2f}, {ref.origin_y:.2f})): placed by its own "
                       "origin and resolution; was it drawn on a copy of this map?", period=30.0)

    def _people_cb(self, msg):
        """The tracker's people into the proxemic layer, in the costmap's frame."""
        from florence_common_ros.transforms import lookup_matrix
        from move_base.people_layer import Person

        n = len(msg.user_ids)
        if n and (len(msg.positions) != n or len(msg.velocities) != n or len(msg.last_seen) != n):
            self._warn("people_fields", f"people message without positions for its {n} users (the seed's three "
                       "fields only?): nobody added")
            people, stamp = [], self._rospy.get_time()
        else:
            frame = strip_slash(msg.frame_id) or self.global_frame
            stamp = msg.stamp.to_sec() if msg.stamp.to_sec() > 0.0 else self._rospy.get_time()
            m = np.eye(4)
            if frame != self.global_frame and n:
                m, why = lookup_matrix(self.tf_buffer, self.global_frame, frame, msg.stamp, 0.1)
                if m is None:
                    self._warn("people_tf", f"people message skipped: {why}")
                    return
            people = []
            for i in range(n):
                p, v = msg.positions[i], msg.velocities[i]
                x, y, _ = m[:3, :3] @ np.array([p.x, p.y, p.z]) + m[:3, 3]
                vx, vy, _ = m[:3, :3] @ np.array([v.x, v.y, v.z])
                people.append(Person(float(x), float(y), float(vx), float(vy), msg.last_seen[i].to_sec(),
                                     int(msg.user_ids[i])))
        with self.lock:
            dropped = self.layered.people.set_people(people, stamp)
        if dropped:
            self._warn("people_nan", f"{dropped} of {n} people at a non-finite position or velocity left out")

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
        m = convert.to_matrix(tf)
        return m[:3, :3], m[:3, 3]

    def _sensor_cb(self, msg, source_name):
        if not self._running:
            return
        now = self._rospy.get_time()
        keep_all = self.layered.obstacles.buffers[source_name].source.observation_persistence > 0.0
        with self._pending_lock:
            queue = self._pending.setdefault(source_name, [])
            if not keep_all:
                queue.clear()
            queue.append((msg, now))
        with self.lock:
            self.layered.obstacles.buffers[source_name].reset_last_updated(now)

    def queued(self, source_name):
        """How many readings of ``source_name`` wait for the next update."""
        with self._pending_lock:
            return len(self._pending.get(source_name, ()))

    def _take_pending(self):
        """Convert the queued sensor messages into observations (see the module docstring)."""
        with self._pending_lock:
            pending, self._pending = self._pending, {}
        for source_name, queue in pending.items():
            for msg, now in queue:
                self._add_reading(msg, source_name, now)

    def _add_reading(self, msg, source_name, now):
        source = self._inputs[source_name]
        src = self.layered.obstacles.buffers[source_name].source
        frame = strip_slash(msg.header.frame_id)
        try:
            if source.data_type == "LaserScan":
                points, free_ends = scan_to_points(
                    msg.ranges,
                    msg.angle_min,
                    msg.angle_increment,
                    msg.range_min,
                    msg.range_max,
                    src.raytrace_range,
                    source.inf_is_valid,
                )
            elif source.data_type == "PointCloud":
                points = np.array([(p.x, p.y, p.z) for p in msg.points], dtype=float).reshape(-1, 3)
                free_ends = None
            else:
                points = convert.cloud_to_points(msg).astype(float)
                free_ends = None
        except ValueError as exc:
            self._warn(f"reading_{source_name}", f"dropped a reading of {source_name}: {exc}")
            return
        if not frame:
            self._warn(f"frame_{source_name}", f"dropped a reading of {source_name}: it has no frame_id")
            return
        tf = self._transform(frame, msg.header.stamp)
        if tf is None:
            return
        rot, trans = tf
        origin = trans
        sensor_frame = source.sensor_frame
        if sensor_frame and sensor_frame != frame:
            tf_origin = self._transform(sensor_frame, msg.header.stamp)
            if tf_origin is None:
                return
            origin = tf_origin[1]
        points = points @ rot.T + trans
        if free_ends is not None:
            free_ends = free_ends @ rot.T + trans
        with self.lock:
            self.layered.obstacles.add_observation(
                source_name, origin, points, free_ends, stamp=msg.header.stamp.to_sec(), now=now
            )

    # --- queries and recoveries ----------------------------------------------------------------
    @property
    def running(self):
        """Whether updates run (between start() and stop())."""
        return self._running

    def update_age(self):
        """Seconds [ROS time] since the last update at the robot's pose, or None before the first."""
        return None if self.last_update is None else self._rospy.get_time() - self.last_update

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
