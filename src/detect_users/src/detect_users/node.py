"""detect_users_node: the stop-and-go search for a user (seed 3.9, Table 12).

On ``detect_user/cmd`` true the robot stops and searches (detect_users.search): before each
45 degree step it calls ``user_tracker_ni_node/Stop``, turns (closed on odometry, through the
velocity multiplexer), calls ``Start``, waits ``~settle_time`` and looks at
``filtered_tracked_users``. The nearest person within ``~max_range`` is published on
``detected_user`` (command true, map frame) and the search ends; a full turn with nobody ends it
ABORTED. ``detect_user/cmd`` false cancels (the robot stops, the tracker is started again).

ROS Parameters: PARAMS below (rendered in the README).

ROS Subscribers:
    detect_user/cmd (std_msgs/Bool): true starts a search (ignored while one runs), false cancels.
    filtered_tracked_users (user_tracker_ni/TrackedUsers): the people, positions in their frame_id.
    odom (nav_msgs/Odometry): the robot's heading and turn rate (the turns close on it).
    map (nav_msgs/OccupancyGrid): people nearer a wall or furniture than ~min_clearance are ghosts.

ROS Publishers:
    cmd_vel (geometry_msgs/Twist): the turns (remapped to the multiplexer's detect_users input);
        a zero Twist when a search ends and on shutdown.
    detected_user (detect_users/DetectedUser): command true, the person's position in ~map_frame.
    approach_user/status (std_msgs/String): ACTIVE (once a second while searching), ABORTED (a full
        turn with nobody, or the tracker or odometry failed), PREEMPTED (cancelled).
    /diagnostics: the search under way and the last outcome with its reason.

ROS Services (client): user_tracker_ni_node/Stop, user_tracker_ni_node/Start (user_tracker_ni/Stop,
    Start; names from ~tracker).
"""

import math
import threading

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import OccupancyGrid, Odometry
from std_msgs.msg import Bool, String

from detect_users.msg import DetectedUser
from detect_users.search import ABORTED, FOUND, Person, Search, SearchParams
from florence_common.grid import Grid
from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros import convert
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import publish_stop, read_params, run
from florence_common_ros.transforms import lookup_matrix
from user_tracker_ni.msg import TrackedUsers
from user_tracker_ni.srv import Start, Stop

LOG = "detect_users: "
_D = SearchParams()
PARAMS = ParamTable(
    Param("steps", int, _D.steps, "45 degree turns of a search (8: a full turn)", ge=1, le=16),
    Param("look_first", bool, _D.look_first, "look at the arrival heading before the first turn ..."),
    Param("reset_first", bool, _D.reset_first, "... with the tracker restarted (Stop, Start) first; false: the "
          "tracks it holds from the way in count (a person too near for the Kinect, whom the laser tracks)"),
    Param("settle_time", float, _D.settle_time, "after Start, before looking", unit="s", ge=0),
    Param("look_time", float, _D.look_time, "a look at one heading lasts this long ...", unit="s", gt=0),
    Param("look_frames", int, _D.look_frames, "... and until the tracker published this many messages since it "
          "looked", ge=0),
    Param("look_timeout", float, _D.look_timeout, "... but no longer (a tracker short of CPU)", unit="s", gt=0),
    Param("max_range", float, _D.max_range, "a person farther from the robot is not in range", unit="m", gt=0),
    Param("min_clearance", float, _D.min_clearance, "a person nearer than this to a wall or furniture of the map "
          "(map) is taken for the tracker's ghost", unit="m", ge=0),
    Param("max_speed", float, _D.max_speed, "fastest turn", unit="rad/s", gt=0),
    Param("min_speed", float, _D.min_speed, "slowest turn command", unit="rad/s", ge=0),
    Param("decel", float, _D.decel, "braking of the turn profile (keep below velocity_filter's max_angular_acc)",
          unit="rad/s^2", gt=0),
    Param("tolerance", float, _D.tolerance, "a heading this near the step's target is reached", unit="rad", gt=0),
    Param("turn_timeout", float, _D.turn_timeout, "longest single turn before the search is aborted", unit="s", gt=0),
    Param("rate", float, 20.0, "control rate of the turns", unit="Hz", gt=0),
    Param("tracker", str, "/user_tracker_ni_node", "namespace of the tracker's Start and Stop services"),
    Param("service_timeout", float, 3.0, "how long a tracker service may take to answer", unit="s", gt=0),
    Param("odom_timeout", float, 1.0, "odometry older than this stops the search (ABORTED)", unit="s", gt=0),
    Param("map_frame", FRAME, "map", "the frame of the published user position"),
    Param("base_frame", FRAME, "base_link", "the robot's frame (distances are measured from it)"),
)


class DetectUsersNode:
    def __init__(self):
        self.p = p = read_params(PARAMS)
        if p.min_speed > p.max_speed:
            raise ValueError(f"~min_speed ({p.min_speed}) must not exceed ~max_speed ({p.max_speed})")
        self.search_params = SearchParams(p.steps, p.look_first, p.reset_first, p.settle_time, p.look_time,
                                          p.look_frames,
                                          p.look_timeout, p.max_range, p.min_clearance, p.max_speed, p.min_speed,
                                          p.decel, p.tolerance, turn_timeout=p.turn_timeout)
        self.lock = threading.Lock()
        self.odom = None  # (t [s], yaw [rad], yaw rate [rad/s])
        self.people = []  # (stamp [s], [Person]) of the tracker messages not yet looked at
        self.search = None
        self.tracker_started_at = 0.0
        self.cancel = threading.Event()
        self.wake = threading.Event()
        self.last = "no search yet"
        self.last_level = OK

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.stop_srv = rospy.ServiceProxy(f"{p.tracker.rstrip('/')}/Stop", Stop)
        self.start_srv = rospy.ServiceProxy(f"{p.tracker.rstrip('/')}/Start", Start)

        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.detected_pub = rospy.Publisher("detected_user", DetectedUser, queue_size=5)
        self.status_pub = rospy.Publisher("approach_user/status", String, queue_size=5)
        self.diag = Diagnostics("detect_users")
        self.diag.add("Search", self._diagnose)

        self.grid = None  # florence_common.grid.Grid of the robot's map
        rospy.Subscriber("map", OccupancyGrid, self._on_map, queue_size=1)
        rospy.Subscriber("odom", Odometry, self._on_odom, queue_size=5)
        rospy.Subscriber("filtered_tracked_users", TrackedUsers, self._on_users, queue_size=10)
        rospy.Subscriber("detect_user/cmd", Bool, self._on_cmd, queue_size=5)
        self.worker = threading.Thread(target=self._run, name="detect_users", daemon=True)
        self.worker.start()

    # --- inputs ---------------------------------------------------------------------------------------------------
    def _on_odom(self, msg):
        try:
            _x, _y, yaw = convert.to_xyyaw(msg)
        except ValueError:
            rospy.logwarn_throttle(5.0, LOG + "odometry with a zero quaternion ignored")
            return
        rate = msg.twist.twist.angular.z
        if not (math.isfinite(yaw) and math.isfinite(rate)):
            rospy.logwarn_throttle(5.0, LOG + "odometry that is not finite ignored")
            return
        with self.lock:
            self.odom = (msg.header.stamp.to_sec(), yaw, rate)

    def _on_map(self, msg):
        info = msg.info
        if info.width * info.height != len(msg.data) or info.resolution <= 0:
            rospy.logwarn(LOG + "map of %dx%d cells with %d values ignored", info.width, info.height, len(msg.data))
            return
        grid = Grid(np.asarray(msg.data, dtype=np.int16).reshape(info.height, info.width),
                    convert.to_xyyaw(info.origin), info.resolution)
        with self.lock:
            self.grid = grid

    def _on_users(self, msg):
        with self.lock:
            looking = self.search is not None
        if not looking:
            return
        if not msg.user_ids:
            with self.lock:
                self.people.append((msg.stamp.to_sec(), []))  # a look without anybody counts too
            return
        if len(msg.positions) != len(msg.user_ids) or not msg.frame_id:
            rospy.logwarn_throttle(5.0, LOG + "filtered_tracked_users without positions or frame_id: cannot place "
                                   "the users")
            return
        # the latest transforms: people count only while the robot stands still, and map -> odom (amcl)
        # changes slowly; a lookup at the message's stamp fails whenever amcl's transform is late
        to_map, why = lookup_matrix(self.tf_buffer, self.p.map_frame, msg.frame_id, rospy.Time(0), 0.0)
        robot, why2 = lookup_matrix(self.tf_buffer, msg.frame_id, self.p.base_frame, rospy.Time(0), 0.0)
        if to_map is None or robot is None:
            rospy.logwarn_throttle(5.0, LOG + "users skipped: %s", why or why2)
            return
        people = []
        with self.lock:
            grid = self.grid
        for uid, pos in zip(msg.user_ids, msg.positions, strict=True):
            if not (math.isfinite(pos.x) and math.isfinite(pos.y)):
                continue
            x, y = (to_map @ np.array([pos.x, pos.y, 0.0, 1.0]))[:2]
            clearance = math.inf if grid is None else float(grid.clearance_at([[x, y]])[0])
            people.append(Person(float(x), float(y), math.hypot(pos.x - robot[0, 3], pos.y - robot[1, 3]), int(uid),
                                 clearance))
        with self.lock:
            self.people.append((msg.stamp.to_sec(), people))

    def _on_cmd(self, msg):
        if msg.data:
            with self.lock:
                busy = self.search is not None
            if busy:
                rospy.loginfo(LOG + "already searching: detect_user/cmd true ignored")
                return
            self.cancel.clear()
            self.wake.set()
        else:
            self.cancel.set()

    # --- the search -----------------------------------------------------------------------------------------------
    def _status(self, text):
        self.status_pub.publish(String(text))

    def _call(self, name):
        proxy, what = (self.stop_srv, "Stop") if name == "stop_tracker" else (self.start_srv, "Start")
        try:
            proxy.wait_for_service(self.p.service_timeout)
            res = proxy()
        except (rospy.ROSException, rospy.ServiceException) as exc:
            return False, f"{proxy.resolved_name}: {exc}"
        if not res.success and "already" not in res.message:
            return False, f"{proxy.resolved_name}: {res.message}"
        if what == "Start":
            self.tracker_started_at = rospy.get_time()
        return True, ""

    def _run(self):
        while not rospy.is_shutdown():
            if not self.wake.wait(0.5):
                continue
            self.wake.clear()
            if self.cancel.is_set():
                continue
            try:
                self._search()
            except rospy.ROSInterruptException:
                return
            except Exception as exc:  # noqa: BLE001 - the search ends with a reason, never a silent thread
                rospy.logerr(LOG + "search failed: %s", exc)
                self._finish(ABORTED, f"internal error: {type(exc).__name__}: {exc}")

    def _search(self):
        p = self.p
        with self.lock:
            odom = self.odom
        now = rospy.get_time()
        if odom is None or now - odom[0] > p.odom_timeout:
            self._finish(ABORTED, "no odometry (odom): cannot turn")
            return
        search = Search(self.search_params, odom[1], now)
        self.tracker_started_at = now if search.phase == "settle" else math.inf  # what counts of the tracker's output
        with self.lock:
            self.search, self.people = search, []
        rospy.loginfo(LOG + "searching from %.0f deg", math.degrees(odom[1]))
        self.cmd_pub.publish(Twist())  # stand still first
        self._status("ACTIVE")
        last_active = now
        rate = rospy.Rate(p.rate)
        while not rospy.is_shutdown():
            now = rospy.get_time()
            if self.cancel.is_set():
                self._finish("PREEMPTED", "cancelled (detect_user/cmd false)")
                return
            with self.lock:
                odom = self.odom
                batches, self.people = self.people, []
            if odom is None or now - odom[0] > p.odom_timeout:
                self._finish(ABORTED, f"odometry silent for {p.odom_timeout:.1f} s: turn stopped")
                return
            fresh = [people for stamp, people in batches if stamp >= self.tracker_started_at]
            seen = [person for people in fresh for person in people]
            looking = search.phase == "look"
            step = search.update(now, odom[1], odom[2], seen if looking else [], len(fresh) if looking else 0)
            if step.call:
                ok, why = self._call(step.call)
                search.called(step.call, ok, why, rospy.get_time())
                continue
            if step.outcome == FOUND:
                person = step.person
                self.detected_pub.publish(DetectedUser(command=True, user_position_x=person.x,
                                                       user_position_y=person.y))
                self._finish(FOUND, f"user {person.user_id} at ({person.x:.2f}, {person.y:.2f}), "
                             f"{person.distance:.1f} m away, after {search.looks + 1} looks"
                             + "".join(f"; {line}" for line in search.log if "published" in line))
                return
            if step.outcome == ABORTED:
                self._finish(ABORTED, step.why + "".join(f"; {line}" for line in search.log if "published" in line))
                return
            cmd = Twist()
            cmd.angular.z = step.w
            self.cmd_pub.publish(cmd)
            if now - last_active >= 1.0:
                self._status("ACTIVE")
                last_active = now
            try:
                rate.sleep()
            except rospy.ROSTimeMovedBackwardsException:
                rate = rospy.Rate(p.rate)

    def _finish(self, outcome, why):
        self.cmd_pub.publish(Twist())
        with self.lock:
            search, self.search = self.search, None
        if search is not None and search.tracker_stopped:
            ok, problem = self._call("start_tracker")  # never leave the tracker stopped
            if not ok:
                rospy.logwarn(LOG + "could not start the tracker again: %s", problem)
        if outcome != FOUND:
            self._status(outcome)
        self.last = f"{outcome}: {why}"
        self.last_level = OK if outcome in (FOUND, "PREEMPTED") else WARN
        (rospy.loginfo if outcome == FOUND else rospy.logwarn)(LOG + "%s", self.last)

    # --- diagnostics and shutdown ------------------------------------------------------------------------------------
    def _diagnose(self, stat):
        with self.lock:
            search = self.search
        if search is not None:
            stat.summary(OK, f"searching: step {search.step} of {self.p.steps}, {search.phase}")
        else:
            stat.summary(self.last_level, self.last)
        stat.add("Last search", self.last)
        return stat

    def shutdown(self):
        self.cancel.set()
        self.diag.shutdown()
        publish_stop(self.cmd_pub)


def main():
    run(DetectUsersNode, "detect_users_node")
