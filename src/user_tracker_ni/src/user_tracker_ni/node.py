"""user_tracker_ni_node: people from the Kinect and the laser, tracked with persistent ids
(seed 3.9, 4.1.2, 4.2; node name as in the seed so its services are /user_tracker_ni_node/Start
and /user_tracker_ni_node/Stop).

ROS Parameters: PARAMS of user_tracker_ni.params (rendered in the README).

ROS Subscribers:
    camera/depth/image (sensor_msgs/Image, 32FC1 [m] or 16UC1 [mm]): the depth image.
    camera/depth/camera_info (sensor_msgs/CameraInfo): its intrinsics.
    camera/rgb/image_color (sensor_msgs/Image, rgb8 or bgr8): the colour image registered to the
        depth image (resized to it when its size differs), for the colour signatures.
    scan (sensor_msgs/LaserScan): the Hokuyo (upside down: placed through tf).
    map (nav_msgs/OccupancyGrid, latched; with ~use_map): the robot's map (map_server's).

ROS Publishers:
    tracked_users (user_tracker_ni/TrackedUsers): the confirmed users after every depth frame (the
        camera rate); after every scan instead while no depth frame came for
        ~publish_on_scans_after. While stopped: an empty message at the same rate.
    tracked_people (user_tracker_ni/TrackedUsers): with every tracked_users message, every
        confirmed person, also those not yet identified (a person the laser found beside or
        close in front of the robot waits up to ~tracker/id_wait_max for the Kinect to see who
        it is before tracked_users shows them); user_ids are the per-appearance ids (as
        user_ids_ni), which a track keeps from its confirmation to its end. For move_base's
        costmaps and anything else that needs where people are, not who.
    ~markers (visualization_msgs/MarkerArray): a cylinder and a label "id (ni id)" per user, an arrow the way
        they face when it is known.
    ~detections (visualization_msgs/MarkerArray, built only while somebody subscribes): what each reading
        detected, in ~fixed_frame: a sphere at chest height per Kinect detection (green; orange when the
        person is partly hidden, grey on the map's walls) and a flat disc at the shins per leg pair of
        the laser (blue; orange or grey alike), each living 0.2 s: why a track went where it went.
    /tf: user_<user_id> per user, child of ~fixed_frame (with ~publish_tf).
    /diagnostics: input rates, processing time, tracks, why detections were dropped.

ROS Services:
    ~Start (user_tracker_ni/Start): track from now on, afresh (harmless while tracking).
    ~Stop (user_tracker_ni/Stop): stop, forget every track and detection (persistent ids and
        their colours are kept, and so is what the laser saw of the free floor, which it goes on
        learning while stopped); harmless while stopped.

Bad input (NaN or empty depth images, a camera_info that does not match the image, missing tf,
colour without depth, NaN/inf in scans) is skipped with a throttled warning that says why; no
callback raises.
"""

import math
import threading
import time
from collections import Counter, deque

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Point, Vector3
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import CameraInfo, Image, LaserScan
from visualization_msgs.msg import Marker, MarkerArray

from florence_common.camera import Camera
from florence_common_ros.convert import depth_image_metres, image_to_array, to_xyyaw, transform_stamped
from florence_common_ros.diagnostics import ERROR, OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from florence_common_ros.transforms import lookup_matrix, lookup_recent_matrix
from user_tracker_ni.msg import TrackedUsers
from user_tracker_ni.params import PARAMS, split
from user_tracker_ni.pipeline import Pipeline
from user_tracker_ni.srv import Start, StartResponse, Stop, StopResponse
from user_tracker_ni.static_map import StaticMap
from user_tracker_ni.tracker import KINECT

LOG = "user_tracker_ni: "
RECENT = 0.5  # [s] a sensor "saw" a user when it did within this long (the sensors field)
COLOURS = [(0.9, 0.2, 0.2), (0.2, 0.5, 0.9), (0.2, 0.8, 0.3), (0.9, 0.7, 0.1), (0.7, 0.3, 0.9), (0.1, 0.8, 0.8)]


def colour_rgb(msg):
    """uint8 RGB array of an rgb8 / bgr8 image."""
    return image_to_array(msg, "rgb8")


class UserTrackerNode:
    def __init__(self):
        self.values, pipeline_params, self.map_params = split(read_params(PARAMS))
        v = self.values
        self.fixed, self.base = v["fixed_frame"], v["base_frame"]
        self.lock = threading.Lock()
        self.pipeline = Pipeline(pipeline_params)
        self.tracker = self.pipeline.tracker
        self.tracking = bool(v["start_tracking"])
        self.map_frame_of_grid = v["map_frame"]
        self.camera = None  # florence_common.camera.Camera of the latest camera_info
        self.camera_key = None
        self.colour = None  # (stamp [s], RGB array) of the latest colour image
        self.last_depth = None  # wall time of the last depth frame processed
        self.stats = Counter()
        self.times = deque(maxlen=200)  # [s] processing time of recent depth frames
        self.warnings = {}
        self.logged = {}  # kind -> monotonic time it was last logged

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.tf_out = tf2_ros.TransformBroadcaster() if v["publish_tf"] else None
        self.pub = rospy.Publisher("tracked_users", TrackedUsers, queue_size=5)
        self.people_pub = rospy.Publisher("tracked_people", TrackedUsers, queue_size=5)
        self.markers = rospy.Publisher("~markers", MarkerArray, queue_size=2)
        self.detections = rospy.Publisher("~detections", MarkerArray, queue_size=5)
        self.diag = Diagnostics("user_tracker_ni")
        self.depth_rate = self.diag.frequency("Depth frames", 5.0, 60.0)
        self.scan_rate = self.diag.frequency("Scans", 5.0, 40.0)
        self.diag.add("Tracking", self._diagnose)
        rospy.Service("~Start", Start, self._start)
        rospy.Service("~Stop", Stop, self._stop)
        rospy.Subscriber("camera/depth/camera_info", CameraInfo, self._on_info, queue_size=1)
        rospy.Subscriber("camera/rgb/image_color", Image, self._on_colour, queue_size=1, buff_size=2**24)
        rospy.Subscriber("camera/depth/image", Image, self._on_depth, queue_size=1, buff_size=2**24)
        rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=1)
        if v["use_map"]:
            rospy.Subscriber("map", OccupancyGrid, self._on_map, queue_size=1)
        rospy.loginfo(LOG + "tracking in %s%s", self.fixed, "" if self.tracking else " once ~Start is called")

    # --- services --------------------------------------------------------------------------------
    def _start(self, _req):
        with self.lock:
            was = self.tracking
            self.pipeline.reset()
            self.tracking = True
        rospy.loginfo(LOG + "Start: tracking afresh%s", " (was tracking)" if was else "")
        return StartResponse(True, "tracking afresh" if not was else "was tracking: restarted afresh")

    def _stop(self, _req):
        with self.lock:
            was = self.tracking
            self.tracking = False
            self.pipeline.reset()
            self.colour = None
        self._publish(rospy.Time.now())
        self._clear_markers()
        rospy.loginfo(LOG + "Stop: every track forgotten%s", "" if was else " (was stopped)")
        return StopResponse(True, "stopped, tracks forgotten" if was else "was stopped already")

    # --- inputs ------------------------------------------------------------------------------------
    def _warn(self, key, text, *args):
        """Note a problem for diagnostics; log it at most every 5 s per kind (``key``)."""
        self.warnings[key] = text % args if args else text
        now = time.monotonic()
        if now - self.logged.get(key, -math.inf) >= 5.0:
            self.logged[key] = now
            rospy.logwarn(LOG + text, *args)

    def _on_info(self, msg):
        key = (tuple(msg.K), msg.width, msg.height)
        if key == self.camera_key:
            return
        try:
            self.camera = Camera.from_k(msg.K, msg.width, msg.height)
            self.camera_key = key
        except ValueError as exc:
            self._warn("camera_info", "camera_info ignored: %s", exc)

    def _on_map(self, msg):
        info = msg.info
        try:
            grid = np.asarray(msg.data, np.int8).reshape(info.height, info.width)
            static = StaticMap(grid, info.resolution, to_xyyaw(info.origin), self.map_params)
        except ValueError as exc:
            self._warn("map", "map ignored: %s", exc)
            return
        with self.lock:
            self.map_frame_of_grid = (msg.header.frame_id or self.values["map_frame"]).lstrip("/")
            self.pipeline.set_map(static)
        rospy.loginfo(LOG + "map %dx%d at %.3f m/cell: detections on its walls and poles start no track",
                      info.width, info.height, info.resolution)

    def _fixed_in_map(self, stamp):
        """4x4 pose of the fixed frame in the map frame at ``stamp``, or None (no map or no transform:
        the check is skipped, and diagnostics say so)."""
        if self.pipeline.map is None:
            return None
        m, _ = lookup_matrix(self.tf_buffer, self.map_frame_of_grid, self.fixed, stamp)
        if m is None:  # the latest will do: map -> odom moves slowly
            m, why = lookup_matrix(self.tf_buffer, self.map_frame_of_grid, self.fixed, rospy.Time(0))
            if m is None:
                self._warn("map_tf", "map check skipped, %s", why)
        return m

    def _on_colour(self, msg):
        try:
            self.colour = (msg.header.stamp.to_sec(), colour_rgb(msg))
        except ValueError as exc:
            self._warn("colour", "colour image skipped: %s", exc)

    def _transform(self, target, source, stamp):
        """4x4 pose of ``source`` in ``target`` at ``stamp``, or None (with a warning naming why)."""
        m, why = lookup_matrix(self.tf_buffer, target, source, stamp, self.values["tf_timeout"])
        if m is None:
            self._warn("tf", "reading skipped, %s", why)
        return m

    def _mount(self, frame, stamp):
        """4x4 pose of the sensor ``frame`` in the base frame at ``stamp``: the latest on tf when it is
        at most ~mount_tolerance older than the reading (a tilt joint published more slowly than the
        camera's frames would otherwise make most frames wait, or be skipped, for the next joint
        state; a mount moves slowly), else looked up at the stamp (waiting up to ~tf_timeout)."""
        m, why, held = lookup_recent_matrix(self.tf_buffer, self.base, frame, stamp, self.values["mount_tolerance"],
                                            self.values["tf_timeout"])
        if m is None:
            self._warn("tf", "reading skipped, %s", why)
        elif held > 0.0:
            self.stats["readings placed by the latest mount"] += 1
        return m

    def _poses(self, frame, stamp):
        """(sensor in base, base in fixed) 4x4 at ``stamp``, or None."""
        sensor = self._mount(frame, stamp)
        if sensor is None:
            return None
        base = self._transform(self.fixed, self.base, stamp)
        return None if base is None else (sensor, base)

    def _on_depth(self, msg):
        self.depth_rate.tick()
        if not self.tracking:
            self._publish(msg.header.stamp)
            return
        started = time.perf_counter()
        try:
            detections = self._depth_detections(msg)
        except ValueError as exc:
            self._warn("depth", "depth frame skipped: %s", exc)
            return
        if detections is None:
            return
        self._publish_detections(detections, msg.header.stamp)
        self.last_depth = time.monotonic()
        self.times.append(time.perf_counter() - started)
        self.stats["depth frames"] += 1
        self._publish(msg.header.stamp)

    def _depth_detections(self, msg):
        """Fuse one depth frame; the detections, or None when it could not be used (warned)."""
        if self.camera is None:
            self._warn("camera_info", "depth frame skipped: no camera_info received yet")
            return None
        depth = depth_image_metres(msg)
        if depth.shape != (self.camera.height, self.camera.width):
            raise ValueError(f"image {depth.shape[1]}x{depth.shape[0]} does not match camera_info "
                             f"{self.camera.width}x{self.camera.height}")
        poses = self._poses(msg.header.frame_id, msg.header.stamp)
        if poses is None:
            return None
        camera_pose, base_pose = poses
        colour = self.colour
        rgb = colour[1] if colour is not None and abs(colour[0] - msg.header.stamp.to_sec()) < 0.1 else None
        fixed_in_map = self._fixed_in_map(msg.header.stamp)
        with self.lock:
            if not self.tracking:
                return None
            return self.pipeline.on_depth(msg.header.stamp.to_sec(), depth, self.camera, camera_pose, base_pose, rgb,
                                          fixed_in_map)

    def _on_scan(self, msg):
        self.scan_rate.tick()
        poses = self._poses(msg.header.frame_id, msg.header.stamp)
        if poses is None:
            return
        laser_pose, base_pose = poses
        fixed_in_map = self._fixed_in_map(msg.header.stamp)
        with self.lock:
            try:  # while stopped, the scan still shows the floor the laser sees free
                detections = self.pipeline.on_scan(msg.header.stamp.to_sec(), msg.ranges, msg.angle_min,
                                                   msg.angle_increment, msg.range_min, msg.range_max,
                                                   base_pose @ laser_pose, fixed_in_map, track=self.tracking)
            except ValueError as exc:
                self._warn("scan", "scan skipped: %s", exc)
                return
        if self.tracking:
            self._publish_detections(detections, msg.header.stamp)
        self.stats["scans"] += 1
        if not self.tracking:
            return
        if self.last_depth is None or time.monotonic() - self.last_depth > self.values["publish_on_scans_after"]:
            self._publish(msg.header.stamp)

    # --- outputs ----------------------------------------------------------------------------------------
    def _publish(self, stamp):
        with self.lock:
            users = self.tracker.published() if self.tracking else []
            people = self.tracker.people() if self.tracking else []
            msg = self._message(stamp, users, [tr.pid for tr in users])
            everyone = self._message(stamp, people, [tr.ni_id for tr in people])
        self.pub.publish(msg)
        self.people_pub.publish(everyone)
        if self.tf_out is not None and msg.user_ids:
            self.tf_out.sendTransform([transform_stamped(stamp, self.fixed, f"{self.values['frame_prefix']}{pid}",
                                                         p.x, p.y, 0.0, z=p.z)
                                       for pid, p in zip(msg.user_ids, msg.positions, strict=True)])
        self._publish_markers(msg)

    def _message(self, stamp, tracks, ids):
        """TrackedUsers of ``tracks`` under ``ids`` (call under the lock)."""
        msg = TrackedUsers(stamp=stamp, frame_id=self.fixed)
        sensors = []  # uint8[]: rospy wants bytes, built once at the end
        now = stamp.to_sec()
        for tr, pid in zip(tracks, ids, strict=True):
            x, y = tr.output(self.tracker.params.coast_limit)
            vx, vy = tr.velocity
            msg.user_ids.append(pid)
            msg.user_ids_ni.append(tr.ni_id)
            msg.positions.append(Point(x, y, 0.85))
            msg.velocities.append(Vector3(vx, vy, 0.0))
            facing = tr.facing(self.tracker.params)
            msg.facings.append(math.nan if facing is None else facing)
            msg.seated.append(tr.seated(self.tracker.params))
            seen = max(t for t in (tr.last_kinect, tr.last_laser) if t is not None)
            msg.last_seen.append(rospy.Time.from_sec(seen))
            sensors.append((1 if tr.last_kinect is not None and now - tr.last_kinect <= RECENT else 0)
                           | (2 if tr.last_laser is not None and now - tr.last_laser <= RECENT else 0))
        msg.sensors = bytes(sensors)
        msg.num_users_tracked = len(msg.user_ids)
        return msg

    def _publish_markers(self, msg):
        out = MarkerArray()
        for pid, ni, p in zip(msg.user_ids, msg.user_ids_ni, msg.positions, strict=True):
            colour = COLOURS[pid % len(COLOURS)]
            body = Marker(type=Marker.CYLINDER, action=Marker.ADD, ns="users", id=pid)
            body.header.frame_id, body.header.stamp = msg.frame_id, msg.stamp
            body.pose.position = Point(p.x, p.y, 0.85)
            body.pose.orientation.w = 1.0
            body.scale = Vector3(0.4, 0.4, 1.7)
            body.color.r, body.color.g, body.color.b, body.color.a = (*colour, 0.5)
            body.lifetime = rospy.Duration(0.5)
            label = Marker(type=Marker.TEXT_VIEW_FACING, action=Marker.ADD, ns="labels", id=pid, text=f"{pid} ({ni})")
            label.header = body.header
            label.pose.position = Point(p.x, p.y, 1.9)
            label.pose.orientation.w = 1.0
            label.scale.z = 0.25
            label.color.r = label.color.g = label.color.b = label.color.a = 1.0
            label.lifetime = rospy.Duration(0.5)
            out.markers += [body, label]
        for pid, p, facing in zip(msg.user_ids, msg.positions, msg.facings, strict=True):
            if not math.isfinite(facing):
                continue
            arrow = Marker(type=Marker.ARROW, action=Marker.ADD, ns="facing", id=pid)  # 0.5 m at the knees
            arrow.header.frame_id, arrow.header.stamp = msg.frame_id, msg.stamp
            tip = Point(p.x + 0.5 * math.cos(facing), p.y + 0.5 * math.sin(facing), 0.5)
            arrow.points = [Point(p.x, p.y, 0.5), tip]
            arrow.scale = Vector3(0.05, 0.1, 0.1)
            arrow.color.r, arrow.color.g, arrow.color.b, arrow.color.a = (*COLOURS[pid % len(COLOURS)], 1.0)
            arrow.lifetime = rospy.Duration(0.5)
            out.markers.append(arrow)
        if out.markers:
            self.markers.publish(out)

    def _publish_detections(self, detections, stamp):
        if not detections or not self.detections.get_num_connections():
            return
        out = MarkerArray()
        for k, det in enumerate(detections):
            kinect = det.source == KINECT
            m = Marker(type=Marker.SPHERE if kinect else Marker.CYLINDER, action=Marker.ADD,
                       ns=f"{det.source}_detections", id=k)
            m.header.frame_id, m.header.stamp = self.fixed, stamp
            m.pose.position = Point(det.x, det.y, 1.2 if kinect else 0.15)
            m.pose.orientation.w = 1.0
            m.scale = Vector3(0.15, 0.15, 0.15) if kinect else Vector3(0.25, 0.25, 0.02)
            colour = ((0.5, 0.5, 0.5) if det.on_structure else (1.0, 0.55, 0.0) if det.across_std is not None
                      else (0.1, 0.8, 0.2) if kinect else (0.2, 0.4, 1.0))
            m.color.r, m.color.g, m.color.b, m.color.a = (*colour, 0.9)
            m.lifetime = rospy.Duration(0.2)
            out.markers.append(m)
        self.detections.publish(out)

    def _clear_markers(self):
        self.markers.publish(MarkerArray(markers=[Marker(action=Marker.DELETEALL)]))

    def _diagnose(self, stat):
        with self.lock:
            tracks = self.tracker.published()
            tentative = len(self.tracker.tracks) - len(tracks)
        problems = sorted(self.warnings.values())
        if self.values["use_map"] and self.pipeline.map is None:
            problems.append("no map yet: ghosts on walls and poles are judged by shape only")
        if not self.tracking:
            stat.summary(OK, "stopped (~Start to track)")
        elif self.camera is None:
            stat.summary(ERROR, "; ".join(["no camera_info: no depth frame can be used", *problems])[:300])
        elif problems:
            stat.summary(WARN, "; ".join(problems)[:300])
        else:
            stat.summary(OK, f"tracking {len(tracks)} user(s)")
        self.warnings = {}
        times = sorted(self.times)
        stat.add("users", len(tracks))
        stat.add("tentative tracks", tentative)
        stat.add("user ids", " ".join(f"{tr.pid}({tr.ni_id})" for tr in tracks))
        stat.add("depth frame p50 (ms)", f"{1000 * times[len(times) // 2]:.1f}" if times else "")
        stat.add("depth frame p99 (ms)", f"{1000 * times[int(0.99 * (len(times) - 1))]:.1f}" if times else "")
        for key, value in sorted(self.stats.items()):
            stat.add(key, value)
        for sensor, count in sorted(self.pipeline.counts.items()):
            stat.add(f"detections: {sensor}", count)
        for reason, count in sorted(self.pipeline.rejected.items()):
            stat.add(f"clusters rejected: {reason}", count)
        for reason, count in sorted(self.pipeline.tracker.dropped.items()):
            stat.add(f"users dropped: {reason}", count)
        return stat


def main():
    run(UserTrackerNode, "user_tracker_ni_node")
