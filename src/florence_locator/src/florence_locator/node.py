"""florence_locator_node: florenceLocator (seed 3.8, Table 11), the room- and hotspot-level
navigation API over move_base, amcl and the user search.

ROS Parameters: PARAMS below (rendered in the README).

ROS Services (florence_locator/srv, at florenceLocator/<name>; every response ends with
``success`` and ``message``):
    getUserPosRoom, getUserPosXYPhi: where the user was last known (room label / x, y, phi).
    getRobotPosRoom, getRobotPosXYPhi: the robot now, from tf map -> ~base_frame (amcl).
    getGoalPosRoom, getGoalPosXYPhi: the most recent move_base goal (the locator's or any client's).
    getHotspot, setHotspot: a labelled (x, y, phi); setHotspot rewrites ~hotspots_file atomically.
    getStatus: actionlib's state name of the current or last activity (florence_locator.activity).
    gotoRoom, gotoXYPhi, gotoUser: answer at once (success = accepted, message = why not) and run
        in the background; a new go-to preempts the running one.
    setUserPosRoom, setUserPosXYPhi: the user's position from a sensor (seed 3.8.1).

ROS Subscribers:
    florenceLocator/manualOverride (std_msgs/Bool): true aborts the activity (every move_base goal,
        the search, the approach) and refuses go-to calls until false.
    approach_user/status (std_msgs/String): detect_users' and approach_me_map's state.
    detected_user (detect_users/DetectedUser): where detect_users found the user (map frame).
    filtered_tracked_users (user_tracker_ni/TrackedUsers): people seen while gotoUser drives to the
        user's room (one there, within ~sighting_range, ends the drive and starts the search).
    map (nav_msgs/OccupancyGrid): the robot's map, to refuse hotspots and goals in walls or off it.
    keepout_map (nav_msgs/OccupancyGrid, optional): the user-drawn keep-out map (table tops, chairs):
        what hides a seated person from the Kinect when gotoUser picks its next place to search from.
    move_base/goal (move_base_msgs/MoveBaseActionGoal): every client's goals (getGoalPos*).
    move_base/waiting_for (geometry_msgs/PointStamped): whom move_base waits for in its way; should it
        give up gotoUser's drive, the robot looks at them from ~look_reach first.

ROS Publishers:
    detect_user/cmd (std_msgs/Bool): start (true) or stop (false) the search.
    detected_user (detect_users/DetectedUser): command false stops approach_me_map.
    ~user_pose (geometry_msgs/PoseStamped, latched): the user's last known pose, for rviz.
    /diagnostics: the activity, manualOverride, the files.

ROS Actions (client): move_base (move_base_msgs/MoveBaseAction).
"""

import http.client
import math
import os
import queue
import threading
import time

import numpy as np
import rosgraph
import rospy
import tf2_ros
from geometry_msgs.msg import PointStamped, PoseStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionGoal, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import Bool, String

from detect_users.msg import DetectedUser
from florence_common import pose as pose2d
from florence_common.grid import Grid
from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros import convert
from florence_common_ros.actions import SentGoal, SimpleActionClient, server_ready_within, state_name
from florence_common_ros.diagnostics import ERROR, OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from florence_common_ros.transforms import lookup_matrix
from florence_locator import srv
from florence_locator.activity import RUNNING, Locator, Timeouts
from florence_locator.places import UNKNOWN, FloorMap, Hotspots, Rooms, check_label, check_pose
from user_tracker_ni.msg import TrackedUsers

LOG = "florence_locator: "
PARAMS = ParamTable(
    Param("rooms_file", str, "", "YAML of the labelled room polygons of the map (rooms: {label: [[x, y], ...]} or "
          "{label: {polygon, hotspot}}); required"),
    Param("hotspots_file", str, "", "YAML of the labelled hotspots (hotspots: {label: {x, y, phi}}), rewritten "
          "atomically by setHotspot; a missing file starts from the rooms file's hotspots; required"),
    Param("map_frame", FRAME, "map", "the frame of rooms, hotspots, goals and the user"),
    Param("base_frame", FRAME, "base_link", "the robot's frame (its pose: tf map_frame -> base_frame)"),
    Param("tf_timeout", float, 0.3, "how long a robot-pose lookup waits for tf", unit="s", ge=0, le=2),
    Param("hotspot_clearance", float, 0.15, "a hotspot or gotoXYPhi goal must be this far from walls, furniture "
          "and unknown space on the map", unit="m", ge=0),
    Param("heartbeat_timeout", float, 5.0, "gotoUser: detect_users or approach_me_map silent this long has failed",
          unit="s", gt=0),
    Param("search_timeout", float, 180.0, "gotoUser: longest search", unit="s", gt=0),
    Param("approach_timeout", float, 240.0, "gotoUser: longest approach", unit="s", gt=0),
    Param("tracker_service", str, "/user_tracker_ni_node/Stop", "gotoUser is refused while no node serves this "
          "('' = no check)"),
    Param("sighting_range", float, 3.0, "gotoUser: a tracked person this near the robot in the user's room, seen "
          "on the way there, ends the drive and starts the search (0 = off) ...", unit="m", ge=0),
    Param("sighting_margin", float, 0.5, "... when this far inside the room (not in its doorways) ...", unit="m",
          ge=0),
    Param("sighting_clearance", float, 0.25, "... and this far from the map's walls and furniture (the tracker's "
          "ghosts sit on door frames and furniture edges)", unit="m", ge=0),
    Param("search_spots", int, 2, "gotoUser: a full turn with nobody moves the robot to another place in the room "
          "to search again, up to this many places (1 = the seed's one full turn) ...", ge=1, le=5),
    Param("lookout_reach", float, 2.5, "... the place nearest this distance from the places searched before (the "
          "Kinect does not see a person seated within about 1.1 m) ...", unit="m", gt=0),
    Param("lookout_clearance", float, 0.45, "... at least this far from walls and furniture of the map (no "
          "doorway), seeing the last place along a free line", unit="m", ge=0),
    Param("lookout_near", float, 1.3, "gotoUser: the next place to search from is the one that sees most of the "
          "room's floor the turns so far did not, between this distance (the Kinect misses a seated person "
          "nearer) ...", unit="m", ge=0),
    Param("lookout_far", float, 4.0, "... and this one, along lines free of the map's and the keep-out map's "
          "obstacles; where no place sees 0.5 m^2 more, the ~lookout_reach rule", unit="m", gt=0),
    Param("look_reach", float, 2.0, "gotoUser: when move_base gives up the drive while somebody stands in its way "
          "(move_base/waiting_for), the robot looks at them from a place about this far that sees them, and "
          "searches from there, once (a still person close in front is unknown to the tracker; 0: give up at "
          "once)", unit="m", ge=0),
    Param("server_wait", float, 3.0, "a go-to call waits this long (wall time) for move_base's action server to "
          "connect before it is refused (a call just after start-up)", unit="s", ge=0, le=30),
)


class FlorenceLocatorNode:
    def __init__(self):
        self.p = p = read_params(PARAMS)
        if not p.rooms_file or not p.hotspots_file:
            raise ValueError("~rooms_file and ~hotspots_file must be set (florence_components.launch sets both)")
        rooms = Rooms.load(p.rooms_file)  # a bad file: YamlError (a ValueError) naming file and line
        if os.path.exists(p.hotspots_file):
            hotspots = Hotspots.load(p.hotspots_file)
        else:
            hotspots = Hotspots(rooms.hotspots, p.hotspots_file)
            rospy.logwarn(LOG + "%s does not exist: starting from the %d hotspots of %s; setHotspot will create it",
                          p.hotspots_file, len(rooms.hotspots), p.rooms_file)
        self.core = Locator(rooms, hotspots, timeouts=Timeouts(p.heartbeat_timeout, p.search_timeout,
                                                                p.approach_timeout),
                            hotspot_clearance=p.hotspot_clearance, sighting_margin=p.sighting_margin,
                            sighting_clearance=p.sighting_clearance, search_spots=p.search_spots,
                            lookout_reach=p.lookout_reach, lookout_clearance=p.lookout_clearance,
                            look_reach=p.look_reach, lookout_sight=(p.lookout_near, p.lookout_far))
        self.lock = threading.RLock()
        self.events = queue.Queue()  # actionlib's callbacks, handled by the tick thread
        self.last_save_error = ""

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.client = SimpleActionClient("move_base", MoveBaseAction)
        self.goal = None  # the newest move_base goal (a SentGoal)

        self.cmd_pub = rospy.Publisher("detect_user/cmd", Bool, queue_size=5)
        self.detected_pub = rospy.Publisher("detected_user", DetectedUser, queue_size=5)
        self.user_pub = rospy.Publisher("~user_pose", PoseStamped, queue_size=1, latch=True)

        self.diag = Diagnostics("florence_locator")
        self.diag.add("Locator", self._diagnose)

        rospy.Subscriber("florenceLocator/manualOverride", Bool, self._on_override, queue_size=5)
        rospy.Subscriber("approach_user/status", String, self._on_status, queue_size=20)
        rospy.Subscriber("detected_user", DetectedUser, self._on_detected, queue_size=5)
        rospy.Subscriber("map", OccupancyGrid, self._on_map, queue_size=1)
        rospy.Subscriber("keepout_map", OccupancyGrid, self._on_keepout, queue_size=1)
        rospy.Subscriber("move_base/goal", MoveBaseActionGoal, self._on_any_goal, queue_size=5)
        rospy.Subscriber("filtered_tracked_users", TrackedUsers, self._on_users, queue_size=2)
        rospy.Subscriber("move_base/waiting_for", PointStamped, self._on_waiting_for, queue_size=2)

        handlers = (
            ("getUserPosRoom", "GetUserPosRoom", self.get_user_pos_room),
            ("getUserPosXYPhi", "GetUserPosXYPhi", self.get_user_pos_xyphi),
            ("getRobotPosRoom", "GetRobotPosRoom", self.get_robot_pos_room),
            ("getRobotPosXYPhi", "GetRobotPosXYPhi", self.get_robot_pos_xyphi),
            ("getGoalPosRoom", "GetGoalPosRoom", self.get_goal_pos_room),
            ("getGoalPosXYPhi", "GetGoalPosXYPhi", self.get_goal_pos_xyphi),
            ("getHotspot", "GetHotspot", self.get_hotspot),
            ("setHotspot", "SetHotspot", self.set_hotspot),
            ("getStatus", "GetStatus", self.get_status),
            ("gotoUser", "GotoUser", self.goto_user),
            ("gotoRoom", "GotoRoom", self.goto_room),
            ("gotoXYPhi", "GotoXYPhi", self.goto_xyphi),
            ("setUserPosRoom", "SetUserPosRoom", self.set_user_pos_room),
            ("setUserPosXYPhi", "SetUserPosXYPhi", self.set_user_pos_xyphi),
        )
        self.services = [rospy.Service(f"florenceLocator/{name}", getattr(srv, cls), handler)
                         for name, cls, handler in handlers]
        self._stop = threading.Event()
        self._ticker = threading.Thread(target=self._tick_loop, name="locator-tick", daemon=True)
        self._ticker.start()
        rospy.loginfo(LOG + "rooms %s (%s); hotspots %s (%s)", p.rooms_file, ", ".join(rooms.labels()),
                      p.hotspots_file, ", ".join(hotspots.labels()))

    # --- plumbing ---------------------------------------------------------------------------------------
    @staticmethod
    def now():
        return rospy.get_time()

    def _execute(self, commands):
        for c in commands:
            if c.name == "send_goal":
                x, y, phi = c.args
                goal = MoveBaseGoal(target_pose=convert.pose_stamped(x, y, phi, self.p.map_frame, rospy.Time.now()))
                aid = c.activity
                self.goal = SentGoal(self.client, goal, active_cb=lambda aid=aid: self._goal_active(aid),
                                     done_cb=lambda s, aid=aid: self._goal_done(aid, s))
            elif c.name == "cancel_goal":
                self.client.cancel_goal()
            elif c.name == "cancel_goals":
                self.client.cancel_all_goals()
            elif c.name == "search":
                self.cmd_pub.publish(Bool(c.args[0]))
            elif c.name == "stop_approach":
                self.detected_pub.publish(DetectedUser(command=False, user_position_x=math.nan,
                                                       user_position_y=math.nan))
        self._publish_user()

    # actionlib calls these with its goal's lock held; taking self.lock there could deadlock with a
    # service that holds self.lock and cancels that goal. They queue the event for the tick thread.
    def _goal_active(self, aid):
        self.events.put(("active", aid))

    def _goal_done(self, aid, state):
        self.events.put(("done", aid, state_name(state), self.client.get_goal_status_text()))

    def _tick_loop(self):
        next_tick = 0.0
        while not self._stop.wait(0.05) and not rospy.is_shutdown():
            try:
                while not self.events.empty():
                    event = self.events.get_nowait()
                    if event[0] == "active":
                        with self.lock:
                            self.core.goal_active(event[1])
                    else:
                        robot, _why = self.robot_pose()
                        with self.lock:
                            self._execute(self.core.goal_done(event[1], event[2], event[3], robot, self.now()))
                with self.lock:
                    if self.goal is not None:
                        self.goal.poll()  # a transition actionlib dropped comes as an event now
                if time.monotonic() >= next_tick:
                    next_tick = time.monotonic() + 0.2
                    with self.lock:
                        self._execute(self.core.tick(self.now()))
            except rospy.ROSException:  # shutting down
                return

    def robot_pose(self):
        """(Pose of the robot on the map, None) or (None, why)."""
        m, why = lookup_matrix(self.tf_buffer, self.p.map_frame, self.p.base_frame, rospy.Time(0), self.p.tf_timeout)
        if m is None:
            return None, f"{why} (is amcl running?)"
        x, y, yaw = pose2d.from_matrix(m[[0, 1, 3]][:, [0, 1, 3]])
        return check_pose(x, y, yaw), None

    def _publish_user(self):
        u = self.core.user
        if u is not None and (u, self.core.user_source) != getattr(self, "_published_user", None):
            self._published_user = (u, self.core.user_source)
            self.user_pub.publish(convert.pose_stamped(u.x, u.y, u.phi, self.p.map_frame, rospy.Time.now()))

    # --- subscribers -------------------------------------------------------------------------------------------
    def _on_override(self, msg):
        with self.lock:
            if bool(msg.data) != self.core.override:
                rospy.logwarn(LOG + "manual override %s", "ON: navigation stopped" if msg.data else "off")
            self._execute(self.core.set_override(msg.data, self.now()))

    def _on_status(self, msg):
        # where a search that found nobody turned (the next place to search is chosen from it)
        robot = self.robot_pose()[0] if msg.data.strip().upper() == "ABORTED" else None
        with self.lock:
            self._execute(self.core.phase_status(msg.data, self.now(), robot))

    def _on_detected(self, msg):
        if not msg.command:
            return
        if not (math.isfinite(msg.user_position_x) and math.isfinite(msg.user_position_y)):
            rospy.logwarn_throttle(5.0, LOG + "detected_user with a position that is not finite: ignored")
            return
        with self.lock:
            self._execute(self.core.detected(msg.user_position_x, msg.user_position_y, self.now()))

    def _on_users(self, msg):
        """People the tracker reports while gotoUser drives to the user's room (activity.Locator.sighted)."""
        with self.lock:
            a = self.core.activity
            driving = a is not None and a.kind == "gotoUser" and a.state in RUNNING and a.phase == "navigate"
        if not driving or self.p.sighting_range <= 0 or not msg.user_ids or len(msg.positions) != len(msg.user_ids):
            return
        to_map, _why = lookup_matrix(self.tf_buffer, self.p.map_frame, msg.frame_id, rospy.Time(0), 0.0)
        robot, _why2 = self.robot_pose()
        if to_map is None or robot is None:
            return
        for q in msg.positions:
            x, y = (to_map @ np.array([q.x, q.y, 0.0, 1.0]))[:2]
            if math.isfinite(x) and math.isfinite(y) and math.hypot(x - robot.x, y - robot.y) <= self.p.sighting_range:
                with self.lock:
                    self._execute(self.core.sighted(float(x), float(y), self.now()))
                return

    def _on_waiting_for(self, msg):
        """Whom move_base waits for (activity.Locator.waiting_for), in the map frame."""
        x, y = msg.point.x, msg.point.y
        frame = msg.header.frame_id.lstrip("/")
        if frame and frame != self.p.map_frame:
            m, _why = lookup_matrix(self.tf_buffer, self.p.map_frame, frame, rospy.Time(0), 0.0)
            if m is None:
                return
            x, y = (m @ np.array([x, y, 0.0, 1.0]))[:2]
        if math.isfinite(x) and math.isfinite(y):
            with self.lock:
                self.core.waiting_for(float(x), float(y))

    def _on_map(self, msg):
        info = msg.info
        if info.width * info.height != len(msg.data) or info.resolution <= 0:
            rospy.logwarn(LOG + "map of %dx%d cells with %d values ignored", info.width, info.height, len(msg.data))
            return
        data = np.asarray(msg.data, dtype=np.int16).reshape(info.height, info.width)
        floor = FloorMap(data, convert.to_xyyaw(info.origin), info.resolution)
        floor.sight_matrix([floor.origin[:2]], [floor.origin[:2]])  # compiles its kernel now, not in a search
        with self.lock:
            self.core.floor = floor
            for label, spot in self.core.hotspots.items():
                problem = self.core.check_place(spot, f"hotspot '{label}'")
                if problem:
                    rospy.logwarn(LOG + "%s: gotoRoom('%s') will be refused until setHotspot moves it", problem, label)

    def _on_keepout(self, msg):
        info = msg.info
        if info.width * info.height != len(msg.data) or info.resolution <= 0:
            rospy.logwarn(LOG + "keep-out map of %dx%d cells with %d values ignored", info.width, info.height,
                          len(msg.data))
            return
        data = np.asarray(msg.data, dtype=np.int16).reshape(info.height, info.width)
        with self.lock:
            self.core.occluders = Grid(data, convert.to_xyyaw(info.origin), info.resolution)
        rospy.loginfo(LOG + "keep-out map %dx%d at %.3f m/cell: what it marks hides a seated person from the next "
                      "place to search from", info.width, info.height, info.resolution)

    def _on_any_goal(self, msg):
        try:
            x, y, yaw = convert.to_xyyaw(msg.goal.target_pose)
            pose = check_pose(x, y, yaw)
        except ValueError:
            return  # a malformed goal: move_base refuses it, and so it was no goal of the robot's
        frame = msg.goal.target_pose.header.frame_id.lstrip("/")
        if frame and frame != self.p.map_frame:
            m, _why = lookup_matrix(self.tf_buffer, self.p.map_frame, frame, rospy.Time(0), 0.0)
            if m is None:
                return
            pose = check_pose(*pose2d.compose(pose2d.from_matrix(m[[0, 1, 3]][:, [0, 1, 3]]), pose.as_tuple()))
        with self.lock:
            self.core.last_goal = pose

    # --- readiness of the pieces gotoUser needs ------------------------------------------------------------------
    def _missing_for_user(self):
        """Why gotoUser cannot run now (a piece is absent), or None."""
        if not server_ready_within(self.client, self.p.server_wait):
            return "move_base is not running (no action server move_base)"
        try:
            # a handle per call: one rosgraph.Master is one HTTP connection, and service calls come
            # in on threads of their own (two at once raise http.client.CannotSendRequest)
            _pubs, subs, services = rosgraph.Master(rospy.get_name()).getSystemState()
        except (rosgraph.MasterError, OSError, http.client.HTTPException) as exc:
            return f"cannot ask the ROS master: {exc}"
        me = rospy.get_name()
        subs = {topic: set(nodes) - {me} for topic, nodes in subs}
        if not subs.get(rospy.resolve_name("detect_user/cmd")):
            return "detect_users is not running (nobody subscribes detect_user/cmd)"
        if not subs.get(rospy.resolve_name("detected_user")):
            return "approach_me_map is not running (nobody else subscribes detected_user)"
        if self.p.tracker_service and not any(name == self.p.tracker_service for name, _ in services):
            return f"the user tracker is not running (no service {self.p.tracker_service})"
        return None

    # --- services ---------------------------------------------------------------------------------------------
    def get_user_pos_room(self, _req):
        with self.lock:
            u = self.core.user
            if u is None:
                return srv.GetUserPosRoomResponse(UNKNOWN, False, "the user's position is not known yet")
            room = self.core.room_of(u)
            return srv.GetUserPosRoomResponse(room, True, f"from {self.core.user_source}")

    def get_user_pos_xyphi(self, _req):
        with self.lock:
            u = self.core.user
            if u is None:
                return srv.GetUserPosXYPhiResponse(math.nan, math.nan, math.nan, False,
                                                   "the user's position is not known yet")
            return srv.GetUserPosXYPhiResponse(u.x, u.y, u.phi, True, f"from {self.core.user_source}")

    def get_robot_pos_room(self, _req):
        robot, why = self.robot_pose()
        if robot is None:
            return srv.GetRobotPosRoomResponse(UNKNOWN, False, why)
        room = self.core.room_of(robot)
        return srv.GetRobotPosRoomResponse(room, True, f"at ({robot.x:.2f}, {robot.y:.2f})")

    def get_robot_pos_xyphi(self, _req):
        robot, why = self.robot_pose()
        if robot is None:
            return srv.GetRobotPosXYPhiResponse(math.nan, math.nan, math.nan, False, why)
        return srv.GetRobotPosXYPhiResponse(robot.x, robot.y, robot.phi, True, f"in {self.core.room_of(robot)}")

    def get_goal_pos_room(self, _req):
        with self.lock:
            g = self.core.last_goal
            if g is None:
                return srv.GetGoalPosRoomResponse(UNKNOWN, False, "no navigation goal yet")
            return srv.GetGoalPosRoomResponse(self.core.room_of(g), True, f"goal ({g.x:.2f}, {g.y:.2f})")

    def get_goal_pos_xyphi(self, _req):
        with self.lock:
            g = self.core.last_goal
            if g is None:
                return srv.GetGoalPosXYPhiResponse(math.nan, math.nan, math.nan, False, "no navigation goal yet")
            return srv.GetGoalPosXYPhiResponse(g.x, g.y, g.phi, True, f"in {self.core.room_of(g)}")

    def get_hotspot(self, req):
        try:
            name = check_label(req.room)
        except ValueError as exc:
            return srv.GetHotspotResponse(math.nan, math.nan, math.nan, False, str(exc))
        spot = self.core.hotspots.get(name)
        if spot is None:
            known = ", ".join(self.core.hotspots.labels())
            return srv.GetHotspotResponse(math.nan, math.nan, math.nan, False,
                                          f"no hotspot '{name}' (hotspots: {known})")
        return srv.GetHotspotResponse(spot.x, spot.y, spot.phi, True, f"hotspot '{name}'")

    def set_hotspot(self, req):
        try:
            name = check_label(req.room)
            pose = check_pose(req.x, req.y, req.phi)
        except ValueError as exc:
            return srv.SetHotspotResponse(False, f"setHotspot: {exc}")
        with self.lock:
            problem = self.core.check_place(pose, f"hotspot '{name}'")
            checked = self.core.floor is not None
        if problem:
            return srv.SetHotspotResponse(False, f"setHotspot refused: {problem}; the old value is kept")
        try:
            self.core.hotspots.set(name, pose)
        except OSError as exc:
            self.last_save_error = f"{self.p.hotspots_file}: {exc}"
            rospy.logerr(LOG + "setHotspot: cannot write %s", self.last_save_error)
            return srv.SetHotspotResponse(False, f"setHotspot: cannot write {self.last_save_error}; nothing changed")
        self.last_save_error = ""
        note = "" if checked else " (not checked against a map: none received yet)"
        rospy.loginfo(LOG + "hotspot '%s' = (%.2f, %.2f, %.2f), saved to %s", name, pose.x, pose.y, pose.phi,
                      self.p.hotspots_file)
        return srv.SetHotspotResponse(True, f"hotspot '{name}' saved to {self.p.hotspots_file}{note}")

    def get_status(self, _req):
        with self.lock:
            state, text = self.core.status()
            if self.core.override and state not in RUNNING:
                text += " (manual override on)"
        return srv.GetStatusResponse(state, True, text)

    def _goto(self, start, response):
        """Run core call ``start(now)`` -> (ok, message, commands) and answer at once."""
        with self.lock:
            ok, message, commands = start(self.now())
            if ok:
                self._execute(commands)
        (rospy.loginfo if ok else rospy.logwarn)(LOG + "%s", message)
        return response(ok, message)

    def goto_room(self, req):
        if not server_ready_within(self.client, self.p.server_wait):
            return srv.GotoRoomResponse(False, "gotoRoom: move_base is not running (no action server move_base)")
        return self._goto(lambda now: self.core.goto_room(req.room, now), srv.GotoRoomResponse)

    def goto_xyphi(self, req):
        try:
            pose = check_pose(req.x, req.y, req.phi)
        except ValueError as exc:
            return srv.GotoXYPhiResponse(False, f"gotoXYPhi: {exc}")
        if not server_ready_within(self.client, self.p.server_wait):
            return srv.GotoXYPhiResponse(False, "gotoXYPhi: move_base is not running (no action server move_base)")
        return self._goto(lambda now: self.core.goto_xyphi(pose, now), srv.GotoXYPhiResponse)

    def goto_user(self, _req):
        with self.lock:
            refusal = self.core._refusal()
        if refusal:
            return srv.GotoUserResponse(False, refusal)
        missing = self._missing_for_user()
        if missing:
            return srv.GotoUserResponse(False, f"gotoUser: {missing}")
        robot, _why = self.robot_pose()
        return self._goto(lambda now: self.core.goto_user(robot, now), srv.GotoUserResponse)

    def set_user_pos_room(self, req):
        with self.lock:
            ok, message = self.core.set_user_room(req.room)
            self._publish_user()
        return srv.SetUserPosRoomResponse(ok, message)

    def set_user_pos_xyphi(self, req):
        try:
            pose = check_pose(req.x, req.y, req.phi)
        except ValueError as exc:
            return srv.SetUserPosXYPhiResponse(False, f"setUserPosXYPhi: {exc}")
        with self.lock:
            ok, message = self.core.set_user_xyphi(pose)
            self._publish_user()
        return srv.SetUserPosXYPhiResponse(ok, message)

    # --- diagnostics and shutdown ----------------------------------------------------------------------------
    def _diagnose(self, stat):
        with self.lock:
            state, text = self.core.status()
            override, user = self.core.override, self.core.user
        level = ERROR if self.last_save_error else (WARN if override else OK)
        summary = self.last_save_error or ("manual override on" if override else f"{state}: {text}")
        stat.summary(level, summary)
        stat.add("Status", state)
        stat.add("Activity", text)
        stat.add("Manual override", str(override))
        stat.add("User", "unknown" if user is None else f"({user.x:.2f}, {user.y:.2f}) in {self.core.room_of(user)}")
        stat.add("Rooms file", self.p.rooms_file)
        stat.add("Hotspots file", self.p.hotspots_file)
        return stat

    def shutdown(self):
        self._stop.set()
        self.diag.shutdown()
        with self.lock:
            commands = self.core.cancel("the locator is shutting down", self.now())
        try:
            self._execute(commands)
            time.sleep(0.05)
        except rospy.ROSException:
            pass


def main():
    run(FlorenceLocatorNode, "florence_locator")
