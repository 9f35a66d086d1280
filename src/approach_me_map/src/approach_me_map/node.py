"""approach_me_map_node: go to a polite pose near a detected user with move_base (seed 3.10,
Table 13).

On ``detected_user`` with command true, the node ranks poses around the user at
``~safe_distance`` + ``~goal_standoff`` (approach_me_map.poses: in front of the user, front-left /
front-right before head-on, never behind her while another pose is free; the front is the way the
tracker says she faces, the robot's side while it does not say, beside her if she sits), asks
move_base's make_plan for a path to the best ones, sends the first with a path as a move_base goal,
and after move_base stops turns to face the user and drives straight to ``~safe_distance`` (the
last half metre, closed on odometry: move_base's 0.25 m goal tolerance is too coarse). A failed
trial moves on to another pose: at most ``~trials`` (3, seed), then ABORTED. The user's position
follows the tracker while the robot approaches.
``detected_user`` with command false stops the approach (its move_base goal is cancelled).

ROS Parameters: PARAMS below (rendered in the README).

ROS Subscribers:
    detected_user (detect_users/DetectedUser): command true: approach the user at (x, y) in
        ~map_frame; command false: stop.
    filtered_tracked_users (user_tracker_ni/TrackedUsers): the user's position while approaching,
        which way she faces (``facings``) and whether she sits (``seated``).
    map (nav_msgs/OccupancyGrid): walls and furniture, to rank the poses.
    scan (sensor_msgs/LaserScan): what is ahead of the robot in the last half metre.
    odom (nav_msgs/Odometry): the robot's speed at rest or not.
    move_base/waiting_for (geometry_msgs/PointStamped): whom move_base waits for; somebody other
        than the user for ~stranger_wait ends the trial, and the next ones keep clear of them.

ROS Publishers:
    approach_user/status (std_msgs/String): ACTIVE (once a second while approaching), SUCCEEDED,
        ABORTED (no free pose, no plan, move_base failed 3 times, or the user was lost), PREEMPTED
        (stopped by command false).
    cmd_vel (geometry_msgs/Twist): the last half metre (remapped to the multiplexer's
        approach_me_map input); a zero Twist at the end and on shutdown.
    ~goal_poses (geometry_msgs/PoseArray, latched): the ranked candidate poses of the last approach.
    move_base/approach_target (geometry_msgs/PointStamped, ~map_frame): the user's place, twice a
        second while a move_base goal runs: move_base keeps her at its approach_person_distance
        instead of min_person_distance (it is sent to her) and does not wait for her to step aside.
    /diagnostics: the approach under way and the last outcome with its reason.

ROS Actions (client): move_base (move_base_msgs/MoveBaseAction).
ROS Services (client): move_base/make_plan (nav_msgs/GetPlan).
"""

import dataclasses
import math
import threading

import numpy as np
import rospy
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PointStamped, PoseArray, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.srv import GetPlan
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from approach_me_map.poses import (
    Align,
    AlignParams,
    ApproachParams,
    ObstacleGrid,
    Stall,
    StrangerWait,
    behind,
    in_the_way,
    judge_way,
    nearest_track,
    rank,
    reaimed,
    still_facings,
    strangers,
)
from detect_users.msg import DetectedUser
from florence_common import angles
from florence_common import pose as pose2d
from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros import convert
from florence_common_ros.actions import SentGoal, SimpleActionClient, server_ready, state_name
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import publish_stop, read_params, run
from florence_common_ros.transforms import lookup_matrix
from user_tracker_ni.msg import TrackedUsers

LOG = "approach_me_map: "
TARGET_PERIOD = 0.5  # [s] between move_base/approach_target messages (move_base lets one lapse after 1.5 s)
FRONT, BESIDE, ROBOT_SIDE = "front", "beside", "robot's side"  # the phases of the trials (_approach)
_A, _L = ApproachParams(), AlignParams()
PARAMS = ParamTable(
    Param("safe_distance", float, _A.safe_distance, "distance from the user's centre to the robot's at the end "
          "(seed DEFAULT_SAFE_DISTANCE)", unit="m", ge=0.45, le=2.0),
    Param("trials", int, 3, "poses sent to move_base before ABORTED (seed: 3)", ge=1),
    Param("plan_checks", int, 8, "candidate poses asked of make_plan for each trial", ge=1),
    Param("candidate_step", float, math.degrees(_A.step), "angle between candidate poses around the user",
          unit="deg", gt=0, le=90),
    Param("preferred_offset", float, math.degrees(_A.preferred_offset), "front-left / front-right: the angle "
          "at the user from the way she faces that costs least", unit="deg", ge=0, le=60),
    Param("use_facing", bool, True, "the front is the way the tracker says the user faces (a seated user's "
          "shins); false, or while it does not say: the robot's side"),
    Param("front_timeout", float, 45.0, "the trials ranked from her facing get this long in all (counted again "
          "after a trial that somebody else stood in the way of); then a trial to the nearest pose not behind her "
          "(a corner seat whose front is tight), with one more if none is left", unit="s", gt=0),
    Param("side_timeout", float, 30.0, "that trial gets this long; then the robot's side, even behind her, with "
          "one more trial if none is left", unit="s", gt=0),
    Param("facing_max_speed", float, 0.25, "a facing is used only while the user's track is slower than this "
          "(a walker's facing is her way, and a still person's track jitters so close up)", unit="m/s", gt=0),
    Param("pass_distance", float, 0.6, "a make_plan path that goes round the user nearer than this (move_base's "
          "min_person_distance) ...", unit="m", ge=0),
    Param("pass_sweep", float, 45.0, "... by more than this angle is taken only when no other pose has a path "
          "(even one behind her: move_base stalls on the way round her)", unit="deg", ge=0),
    Param("max_detour", float, 2.5, "likewise a path longer than the straight line from the robot to the pose by "
          "more than this: the way round the furniture to a seated user's front, 7-13 m for 2 m, which the "
          "robot loses and finds again as the tracker loses and finds her", unit="m", ge=0),
    Param("stranger_distance", float, 0.6, "likewise a path that passes nearer than this (move_base's "
          "min_person_distance) to another tracked person standing still: move_base would wait for them (one seen so "
          "near what is left of the way ends the trial)",
          unit="m", ge=0),
    Param("stranger_wait", float, 8.0, "move_base waiting this long for somebody other than the user (its "
          "waiting_for farther than ~track_gate from her) ends the trial; the next trials take them for a "
          "stranger standing there", unit="s", gt=0),
    Param("min_clearance", float, _A.min_clearance, "a pose this near walls or furniture of the map is not "
          "used", unit="m", ge=0),
    Param("goal_timeout", float, 120.0, "longest move_base trial", unit="s", gt=0),
    Param("goal_standoff", float, 0.1, "move_base's goal this much beyond safe_distance, the last half metre driving "
          "the rest (move_base's people layer keeps plans 0.47 m from the user's tracked centre: a goal at 0.5 m "
          "fell into that as her track moved); with ~align false, none", unit="m", ge=0, le=0.5),
    Param("reaim_distance", float, 0.1, "the tracked user this far from where the pose was put around her: the "
          "move_base goal moves with her (same place around her), unless that is within ~min_clearance of the "
          "map's furniture", unit="m", gt=0),
    Param("reaim_period", float, 2.0, "at most one such move in this long", unit="s", ge=0),
    Param("stall_timeout", float, 5.0, "move_base's robot standing still this long within ~stall_radius of the "
          "pose: its goal ends and the last half metre starts from there", unit="s", gt=0),
    Param("stall_radius", float, 0.6, "how near the pose a stall counts (move_base's xy_goal_tolerance is 0.25 m)",
          unit="m", gt=0),
    Param("stall_linger", float, 12.0, "move_base's robot within ~stall_radius of the pose this long however it "
          "moves (turning to and fro beside a chair): the same, unless it is behind the user (the next trial)",
          unit="s", gt=0),
    Param("align", bool, True, "after move_base, turn to the user and drive to safe_distance (the last half "
          "metre); false: move_base's tolerance only"),
    Param("align_speed", float, _L.max_speed, "fastest straight move of the last half metre", unit="m/s", gt=0,
          le=0.3),
    Param("front_margin", float, _L.front_margin, "free space kept ahead of the robot's nose in the last half "
          "metre (laser)", unit="m", ge=0),
    Param("accept_distance", float, _L.accept_distance, "success: within this of safe_distance ...", unit="m",
          gt=0),
    Param("accept_angle", float, math.degrees(_L.accept_angle), "... and facing the user within this",
          unit="deg", gt=0),
    Param("blocked_accept", float, _L.blocked_accept, "success too: the straight move blocked ahead (a seated "
          "user's knees, a table) at most this beyond safe_distance", unit="m", ge=0),
    Param("nose", float, 0.24, "the robot's front edge from its centre (the footprint's tip)", unit="m", gt=0),
    Param("half_width", float, 0.19, "half the robot's width, plus a margin (the corridor checked ahead)",
          unit="m", gt=0),
    Param("track_gate", float, 0.6, "a tracked person this near the user's position is the user", unit="m",
          gt=0),
    Param("retarget_distance", float, 0.5, "the user moved this far: the trial starts over from there",
          unit="m", gt=0),
    Param("rate", float, 20.0, "control rate of the last half metre", unit="Hz", gt=0),
    Param("map_frame", FRAME, "map", "the frame of detected_user, the map and the goals"),
    Param("odom_frame", FRAME, "odom", "the frame the last half metre closes on"),
    Param("base_frame", FRAME, "base_link", "the robot's frame"),
)


class Cancelled(Exception):
    pass


class ApproachMeMapNode:
    def __init__(self):
        self.p = p = read_params(PARAMS)
        self.params = ApproachParams(p.safe_distance, math.radians(p.candidate_step), math.radians(p.preferred_offset),
                                     min_clearance=p.min_clearance)
        self.align_params = AlignParams(p.safe_distance, p.align_speed, front_margin=p.front_margin,
                                        accept_distance=p.accept_distance, accept_angle=math.radians(p.accept_angle),
                                        blocked_accept=p.blocked_accept)
        self.lock = threading.Lock()
        self.grid = None
        self.request = None  # (x, y) of the newest detection not yet taken
        self.user = None  # (x, y) [m, map] of the user being approached
        self.facing = None  # [rad, map] which way she faces (the tracker's latest word), None: unknown
        self.seated = False  # whether she sits (the tracker's latest word)
        self.track_seated = np.zeros(0, dtype=bool)  # of the latest tracked users, in self.tracks' order
        # the latest tracked users: xy [m, map], facings [rad, map], speeds [m/s] (NaN: not given)
        self.tracks = (np.empty((0, 2)), np.empty(0), np.empty(0))
        self.scan = None  # (stamp [s], points [N, 2] in base_frame)
        self.waiting_for = None  # ((x, y) [m, map], ROS time [s] received): move_base's last ~waiting_for
        self.met = []  # (x, y) [m, map] of the strangers move_base waited for or the robot saw in its way
        self.speed = (0.0, 0.0, -math.inf)  # v [m/s], w [rad/s], stamp [s]
        self.running = False
        self.cancel = threading.Event()
        self.wake = threading.Event()
        self.last = "no approach yet"
        self.last_level = OK

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.client = SimpleActionClient("move_base", MoveBaseAction)
        self.make_plan = rospy.ServiceProxy("move_base/make_plan", GetPlan)

        self.status_pub = rospy.Publisher("approach_user/status", String, queue_size=5)
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.poses_pub = rospy.Publisher("~goal_poses", PoseArray, queue_size=1, latch=True)
        self.target_pub = rospy.Publisher("move_base/approach_target", PointStamped, queue_size=1)
        self.diag = Diagnostics("approach_me_map")
        self.diag.add("Approach", self._diagnose)

        rospy.Subscriber("map", OccupancyGrid, self._on_map, queue_size=1)
        rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=1)
        rospy.Subscriber("odom", Odometry, self._on_odom, queue_size=5)
        rospy.Subscriber("filtered_tracked_users", TrackedUsers, self._on_users, queue_size=5)
        rospy.Subscriber("detected_user", DetectedUser, self._on_detected, queue_size=5)
        rospy.Subscriber("move_base/waiting_for", PointStamped, self._on_waiting_for, queue_size=5)
        self.worker = threading.Thread(target=self._run, name="approach_me_map", daemon=True)
        self.worker.start()

    # --- inputs --------------------------------------------------------------------------------------------------
    def _on_map(self, msg):
        info = msg.info
        if info.width * info.height != len(msg.data) or info.resolution <= 0:
            rospy.logwarn(LOG + "map of %dx%d cells with %d values ignored", info.width, info.height, len(msg.data))
            return
        grid = ObstacleGrid(np.asarray(msg.data, dtype=np.int16).reshape(info.height, info.width),
                            convert.to_xyyaw(info.origin), info.resolution)
        with self.lock:
            self.grid = grid

    def _on_scan(self, msg):
        with self.lock:
            if not self.running:
                return
        m, why = lookup_matrix(self.tf_buffer, self.p.base_frame, msg.header.frame_id, rospy.Time(0), 0.0)  # fixed
        if m is None:
            rospy.logwarn_throttle(5.0, LOG + "scan skipped: %s", why)
            return
        r = np.asarray(msg.ranges, dtype=float)
        a = msg.angle_min + msg.angle_increment * np.arange(len(r))
        ok = np.isfinite(r) & (r > msg.range_min) & (r < msg.range_max)
        pts = np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok]), np.zeros(ok.sum()), np.ones(ok.sum())])
        base = (m @ pts.T).T[:, :2]
        with self.lock:
            self.scan = (msg.header.stamp.to_sec(), base)

    def _on_odom(self, msg):
        v, w = msg.twist.twist.linear.x, msg.twist.twist.angular.z
        if math.isfinite(v) and math.isfinite(w):
            with self.lock:
                self.speed = (v, w, msg.header.stamp.to_sec())

    def _on_users(self, msg):
        if not msg.user_ids or len(msg.positions) != len(msg.user_ids) or not msg.frame_id:
            return
        # the latest map -> frame_id (amcl's map -> odom changes slowly; a lookup at the stamp fails
        # whenever amcl's transform comes late)
        m, why = lookup_matrix(self.tf_buffer, self.p.map_frame, msg.frame_id, rospy.Time(0), 0.0)
        if m is None:
            rospy.logwarn_throttle(5.0, LOG + "tracked users skipped: %s", why)
            return
        pts = np.array([[q.x, q.y, 0.0, 1.0] for q in msg.positions])
        xy = (m @ pts.T).T[:, :2]
        facings = np.full(len(xy), np.nan)
        speeds = np.array([math.hypot(v.x, v.y) for v in msg.velocities] if len(msg.velocities) == len(xy)
                          else np.full(len(xy), np.nan))
        if self.p.use_facing and len(msg.facings) == len(xy):
            facings = np.asarray(msg.facings, dtype=float) + pose2d.yaw_of_matrix(m[:3, :3])  # NaN stays NaN
            facings = still_facings(facings, np.nan_to_num(speeds, nan=0.0), self.p.facing_max_speed)
        seated = np.array(msg.seated, dtype=bool) if len(msg.seated) == len(xy) else np.zeros(len(xy), dtype=bool)
        with self.lock:
            self.tracks, self.track_seated = (xy, facings, speeds), seated
            user = self.user if self.running else None
        if user is None:
            return
        k = nearest_track(user, xy, self.p.track_gate)
        if k is None:
            return
        with self.lock:
            if self.running:
                self.user = (float(xy[k, 0]), float(xy[k, 1]))
                self.seated = bool(seated[k])
                if math.isfinite(facings[k]):
                    self.facing = float(angles.wrap(facings[k]))

    def _on_waiting_for(self, msg):
        m, why = lookup_matrix(self.tf_buffer, self.p.map_frame, msg.header.frame_id, rospy.Time(0), 0.0)
        xy = None if m is None else (m @ np.array([msg.point.x, msg.point.y, msg.point.z, 1.0]))[:2]
        if xy is None or not np.isfinite(xy).all():
            rospy.logwarn_throttle(5.0, LOG + "move_base/waiting_for skipped: %s", why or "not finite")
            return
        with self.lock:
            self.waiting_for = ((float(xy[0]), float(xy[1])), rospy.get_time())

    def _on_detected(self, msg):
        if not msg.command:
            with self.lock:
                self.request = None
            self.cancel.set()
            return
        x, y = msg.user_position_x, msg.user_position_y
        if not (math.isfinite(x) and math.isfinite(y)):
            rospy.logwarn(LOG + "detected_user at a position that is not finite: ignored")
            return
        with self.lock:
            self.request = (float(x), float(y))
        self.cancel.set()  # a new user position: the running approach (if any) gives way
        self.wake.set()

    # --- the approach ------------------------------------------------------------------------------------------------
    def _status(self, text):
        self.status_pub.publish(String(text))

    def _run(self):
        while not rospy.is_shutdown():
            if not self.wake.wait(0.5):
                continue
            self.wake.clear()
            with self.lock:
                request, self.request = self.request, None
            if request is None:
                continue
            self.cancel.clear()
            with self.lock:
                self.user, self.running = request, True
                xy, facings, _ = self.tracks
                k = nearest_track(request, xy, self.p.track_gate)
                self.facing = float(angles.wrap(facings[k])) if k is not None and math.isfinite(facings[k]) else None
                self.seated = k is not None and bool(self.track_seated[k])
            outcome, why = "ABORTED", ""
            try:
                outcome, why = self._approach()
            except Cancelled:
                outcome, why = "PREEMPTED", "stopped (detected_user command false, or a new detection)"
            except rospy.ROSInterruptException:
                return
            except Exception as exc:  # noqa: BLE001 - every approach ends with a reason
                rospy.logerr(LOG + "approach failed: %s", exc)
                outcome, why = "ABORTED", f"internal error: {type(exc).__name__}: {exc}"
            finally:
                with self.lock:
                    self.running = False
                self.cmd_pub.publish(Twist())
            self.last = f"{outcome}: {why}"
            self.last_level = OK if outcome in ("SUCCEEDED", "PREEMPTED") else WARN
            (rospy.loginfo if outcome != "ABORTED" else rospy.logwarn)(LOG + "%s", self.last)
            self._status(outcome)

    def _check(self):
        if self.cancel.is_set() or rospy.is_shutdown():
            raise Cancelled

    def _robot(self, frame):
        m, why = lookup_matrix(self.tf_buffer, frame, self.p.base_frame, rospy.Time(0), 0.3)
        return (None, why) if m is None else (pose2d.from_matrix(m[[0, 1, 3]][:, [0, 1, 3]]), None)

    def _heartbeat(self, state):
        now = rospy.get_time()
        if now - state.get("active", -math.inf) >= 1.0:
            self._status("ACTIVE")
            state["active"] = now

    def _approach(self):
        p = self.p
        beat = {}
        self._heartbeat(beat)
        if not server_ready(self.client):
            return "ABORTED", "move_base is not running"
        tried, notes = [], []
        started, learnt = rospy.get_time(), False
        phase = FRONT  # then BESIDE (her front not reached in time), then ROBOT_SIDE
        with self.lock:
            self.met = []
        trial, limit = 0, p.trials
        while trial < limit:
            trial += 1
            self._check()
            robot, why = self._robot(p.map_frame)
            if robot is None:
                return "ABORTED", f"no robot pose: {why}"
            with self.lock:
                user, grid, facing = self.user, self.grid, None if phase == ROBOT_SIDE else self.facing
                seated = self.seated and phase == FRONT
            if phase == BESIDE and facing is None:
                phase = ROBOT_SIDE
            # move_base's goal ~goal_standoff beyond safe_distance (the last half metre drives the rest):
            # its people layer keeps plans 0.3 m + the inscribed radius (0.47 m) from the tracked centre of the
            # very user approached, and a goal at 0.5 m fell into that as her track moved a few cm (make demo:
            # "the goal is in an obstacle", recoveries, 60 s waiting); then safe_distance, then a little farther
            first = self.params.safe_distance + (p.goal_standoff if p.align else 0.0)
            radii = [first] + [r for r in (self.params.safe_distance, self.params.safe_distance + 0.1,
                                            self.params.safe_distance + 0.2) if abs(r - first) > 1e-6]
            goal = None
            for k, radius in enumerate(radii[:3]):
                ring = dataclasses.replace(self.params, safe_distance=radius)
                candidates = rank(user, robot[:2], ring, grid, exclude=tried, facing=facing, seated=seated,
                                  not_behind=phase == BESIDE)
                if trial == 1 and k == 0:
                    self._publish_candidates(candidates)
                goal, way = self._plannable(candidates, robot, beat, user)
                if goal is not None:
                    if k:
                        notes.append(f"trial {trial}: no pose {first:.2f} m from the user had a path, move_base "
                                     f"sent {radius:.2f} m out")
                    break
            if goal is None and phase == BESIDE:  # no pose beside her has a way: the robot's side, this trial
                notes.append(f"trial {trial}: no pose beside the user, not behind her, with a path")
                phase, trial = ROBOT_SIDE, trial - 1
                continue
            if goal is None:
                notes.append(f"trial {trial}: no pose around ({user[0]:.2f}, {user[1]:.2f}) with a path"
                             + ("" if candidates else " (none free on the map)"))
                break
            tried.append(goal.angle)
            if facing is None:
                deadline = math.inf
            else:
                deadline = started + p.front_timeout if phase == FRONT else rospy.get_time() + p.side_timeout
            with self.lock:
                met = len(self.met)
            ok, why = self._drive(goal, user, beat, last=trial == limit, use_facing=facing is not None,
                                  deadline=deadline, way=way, learn_facing=seated and facing is None)
            with self.lock:
                if len(self.met) > met:  # somebody else in the way, not her front out of reach: a new budget
                    started = rospy.get_time()
            front = (f"her facing {math.degrees(facing):.0f} deg" + (", beside her" if phase == BESIDE else "")
                     if facing is not None else "the robot's side, beside her" if seated else "the robot's side")
            notes.append(f"trial {trial} at {math.degrees(goal.offset):+.0f} deg from {front}: {why}")
            if ok:
                return "SUCCEEDED", "; ".join(notes)
            with self.lock:
                seen = self.facing is not None
            if seated and facing is None and seen and not learnt:
                # her facing came while the trial ran: the next ones are ranked from it, one more if none is left
                learnt, limit, started = True, max(limit, trial + 1), rospy.get_time()
            if facing is not None and rospy.get_time() >= deadline:
                # her front is out of reach (a corner seat, her knees, the tracker's facing off): beside her,
                # then the robot's side, each with one more trial if this was the last
                phase, limit = (BESIDE if phase == FRONT else ROBOT_SIDE), max(limit, trial + 1)
        return "ABORTED", "; ".join(notes) or "no trial"

    def _others(self, user):
        """Where the people other than the user stand (module poses' strangers): the tracked ones standing
        still, and those move_base waited for or the robot saw in its way in this approach. (S, 2) [m, map]."""
        with self.lock:
            xy, _, speeds = self.tracks
            met = list(self.met)
        return np.vstack([strangers(xy, np.nan_to_num(speeds, nan=0.0), user, self.p.track_gate,
                                    self.p.facing_max_speed), np.reshape(met, (-1, 2))])

    def _plannable(self, candidates, robot, beat, user):
        """(candidate, way): the first candidate with a plan that neither goes round the user, nor passes
        near somebody else standing (module poses), nor is a detour (~max_detour), with its plan's path
        (N, 2) [m, map]; else the one whose plan passes nobody, is no detour and goes least round her,
        in that order, with None; else (None, None)."""
        others = self._others(user)
        fallback, least, seen = None, (True, True, math.inf), []
        chosen = way = None
        for c in candidates[:self.p.plan_checks]:
            self._check()
            self._heartbeat(beat)
            try:
                self.make_plan.wait_for_service(2.0)
                plan = self.make_plan(start=convert.pose_stamped(*robot, self.p.map_frame, rospy.Time.now()),
                                      goal=convert.pose_stamped(c.x, c.y, c.yaw, self.p.map_frame, rospy.Time.now()),
                                      tolerance=0.0).plan
            except (rospy.ROSException, rospy.ServiceException) as exc:
                rospy.logwarn_throttle(5.0, LOG + "make_plan failed: %s", exc)
                continue
            if not plan.poses:
                seen.append(f"{math.degrees(c.offset):+.0f} deg: no path")
                continue
            path = [(q.pose.position.x, q.pose.position.y) for q in plan.poses]
            rank, why = judge_way(path, robot, (c.x, c.y), user, others, self.p.pass_distance,
                                  math.radians(self.p.pass_sweep), self.p.stranger_distance, self.p.max_detour)
            if not why:
                chosen, way = c, np.asarray(path)
                break
            seen.append(f"{math.degrees(c.offset):+.0f} deg: the way {why}")
            if rank < least:
                fallback, least = c, rank
        chosen = chosen or fallback
        if seen:
            rospy.loginfo(LOG + "poses asked of make_plan before the one taken (%s): %s",
                          "none" if chosen is None else f"{math.degrees(chosen.offset):+.0f} deg", "; ".join(seen))
        return chosen, way

    def _drive(self, goal, user, beat, last, use_facing=True, deadline=math.inf, way=None, learn_facing=False):
        """One trial: move_base to ``goal``, then the last half metre (``last``: the last trial). (ok, what
        happened). ``use_facing``: the trial ranked from her facing (else from the robot's side, and
        ending at her back is no failure); past ``deadline`` [s] (ROS time) it ends; ``way``: make_plan's
        path (N, 2) [m, map], clear of everybody else when chosen: somebody seen standing near what is
        left of it ends the trial; ``learn_facing``: ranked beside a seated user whose facing was unknown,
        the trial ends once the tracker says it and the pose is behind her (not for a standing user: the
        tracker's facing of one whose top the image cuts off close up may be anything)."""
        p = self.p
        done = threading.Event()
        aim, target = user, (goal.x, goal.y)  # the user's place the pose was put around, and the pose

        def send():
            done.clear()
            sent_goal[0] = SentGoal(self.client, MoveBaseGoal(target_pose=convert.pose_stamped(
                *target, goal.yaw, p.map_frame, rospy.Time.now())), done_cb=lambda _state: done.set())
            return rospy.get_time()

        sent_goal = [None]
        started = sent = send()
        stall, stalled, moves = Stall(p.stall_radius, p.stall_timeout, linger=p.stall_linger), "", 0
        announced, waited = -math.inf, StrangerWait(p.stranger_wait, p.track_gate)
        ended = None  # why the trial ended before move_base did
        try:
            while not done.wait(0.1) and not sent_goal[0].poll():
                self._check()
                self._heartbeat(beat)
                with self.lock:
                    now_user = self.user
                if rospy.get_time() - announced >= TARGET_PERIOD:
                    announced = rospy.get_time()
                    self._announce(now_user)
                if math.hypot(now_user[0] - user[0], now_user[1] - user[1]) > p.retarget_distance:
                    ended = f"the user moved to ({now_user[0]:.2f}, {now_user[1]:.2f})"
                    break
                if learn_facing:
                    with self.lock:
                        facing = self.facing
                    if facing is not None and behind(now_user, target, facing, self.params.side_limit):
                        ended = f"her facing seen ({math.degrees(facing):.0f} deg): the pose is behind her"
                        break
                shift = (now_user[0] - aim[0], now_user[1] - aim[1])
                if math.hypot(*shift) > p.reaim_distance and rospy.get_time() - sent > p.reaim_period:
                    # the tracker places her better as the robot comes closer (amcl's error, a far
                    # sighting): the pose keeps its place around her, so it stays safe_distance away;
                    # not into the furniture (a pose beside a table, moved 0.12-0.16 m with her track's
                    # jitter, fell within the table's inscribed ring: move_base ran its recoveries
                    # for 30 s, "the goal is in an obstacle"); the last half metre aims at her anyway
                    with self.lock:
                        grid = self.grid
                    moved = reaimed(target, shift, grid, p.min_clearance)
                    if moved is not None:
                        aim, target = now_user, moved
                        sent, moves = send(), moves + 1
                        rospy.loginfo(LOG + "the user is %.2f m from where the pose was put: pose moved to "
                                      "(%.2f, %.2f)", math.hypot(*shift), *target)
                    else:
                        aim, sent = now_user, rospy.get_time()
                        rospy.loginfo(LOG + "the user is %.2f m from where the pose was put: the pose stays, moved "
                                      "it would be within ~min_clearance of the map's furniture", math.hypot(*shift))
                now = rospy.get_time()
                if now - started > p.goal_timeout or now > deadline:
                    ended = (f"move_base took longer than {p.goal_timeout:.0f} s" if now <= deadline else
                             f"not reached within its time (~front_timeout {p.front_timeout:.0f} s, "
                             f"~side_timeout {p.side_timeout:.0f} s)")
                    break
                with self.lock:
                    waiting_for = self.waiting_for
                stranger = waited.update(now, now_user, waiting_for)
                if stranger is not None:
                    with self.lock:
                        self.met.append(stranger)
                    ended = (f"move_base waited {p.stranger_wait:.0f} s for somebody at ({stranger[0]:.2f}, "
                             f"{stranger[1]:.2f}), not the user")
                    break
                robot, _ = self._robot(p.map_frame)
                blocking = in_the_way(way, robot[:2], self._others(now_user), p.stranger_distance) \
                    if way is not None and robot is not None else ()
                if len(blocking):
                    with self.lock:
                        self.met.extend(tuple(map(float, b)) for b in blocking)
                    ended = f"somebody stands in the way at ({blocking[0][0]:.2f}, {blocking[0][1]:.2f})"
                    break
                if robot is not None and stall.update(rospy.get_time(), robot, target):
                    self.client.cancel_goal()
                    stalled = (f"move_base's robot {stall.why}, "
                               f"{math.hypot(robot[0] - target[0], robot[1] - target[1]):.2f} m from the pose; ")
                    rospy.loginfo(LOG + stalled + "the last half metre from there")
                    break
        except Cancelled:
            self.client.cancel_goal()
            raise
        if ended:
            self.client.cancel_goal()
            return False, ended
        state = self.client.get_state()
        text = self.client.get_goal_status_text()
        robot, _ = self._robot(p.map_frame)
        with self.lock:
            now_user = self.user
        near = robot is not None and math.hypot(robot[0] - now_user[0], robot[1] - now_user[1]) \
            < p.safe_distance + 0.6
        if state != GoalStatus.SUCCEEDED:
            if not near and not stalled:
                return False, f"move_base {state_name(state)}: {text}"
            with self.lock:
                facing = self.facing if use_facing else None
            if not last and behind(now_user, robot, facing, self.params.side_limit):  # it would end at her back
                return False, stalled + f"move_base {state_name(state)} behind the user: {text}"
        moved = f"the pose moved {moves} time(s) with her; " if moves else ""
        if not p.align:
            return True, moved + stalled + f"move_base {state_name(state)}"
        ok, why = self._align(beat)
        return ok, moved + stalled + why

    def _announce(self, user):
        """Tell move_base whom it is sent to (``move_base/approach_target``)."""
        msg = PointStamped()
        msg.header.stamp, msg.header.frame_id = rospy.Time.now(), self.p.map_frame
        msg.point.x, msg.point.y = user
        self.target_pub.publish(msg)

    def _align(self, beat):
        """The last half metre in the odometry frame."""
        p = self.p
        align = Align(self.align_params, rospy.get_time())
        rate = rospy.Rate(p.rate)
        while True:
            self._check()
            self._heartbeat(beat)
            m, why = lookup_matrix(self.tf_buffer, p.odom_frame, p.map_frame, rospy.Time(0), 0.3)
            robot, why2 = self._robot(p.odom_frame)
            if m is None or robot is None:
                return False, f"last half metre: {why or why2}"
            with self.lock:
                user_map, speed, scan, grid = self.user, self.speed, self.scan, self.grid
            user = tuple((m @ np.array([user_map[0], user_map[1], 0.0, 1.0]))[:2])
            front = self._front_free(scan)
            back = self._back_free(grid)
            step = align.update(rospy.get_time(), robot, speed[:2], user, front, back)
            if step.done:
                self.cmd_pub.publish(Twist())
                return step.ok, f"last half metre: {step.why}"
            cmd = Twist()
            cmd.linear.x, cmd.angular.z = step.v, step.w
            self.cmd_pub.publish(cmd)
            try:
                rate.sleep()
            except rospy.ROSTimeMovedBackwardsException:
                rate = rospy.Rate(p.rate)

    def _front_free(self, scan):
        """Free distance [m] ahead of the nose in the robot's corridor (inf with no scan)."""
        if scan is None or rospy.get_time() - scan[0] > 1.0:
            return 0.0  # no fresh scan: do not drive forward blind
        pts = scan[1]
        ahead = pts[(pts[:, 0] > 0.0) & (np.abs(pts[:, 1]) <= self.p.half_width)]
        return float(np.min(ahead[:, 0]) - self.p.nose) if len(ahead) else math.inf

    def _back_free(self, grid):
        """Free distance [m] behind the robot on the map (0 without one): how far it may back up."""
        robot, _ = self._robot(self.p.map_frame)
        if grid is None or robot is None:
            return 0.0
        back = [pose2d.compose(robot, (-d, 0.0, 0.0))[:2] for d in np.arange(0.0, 0.3, 0.02)]
        free = grid.free_within(back, self.p.half_width)
        blocked = np.nonzero(~free)[0]
        return 0.3 if not len(blocked) else float(blocked[0] * 0.02)

    def _publish_candidates(self, candidates):
        msg = PoseArray()
        msg.header.frame_id, msg.header.stamp = self.p.map_frame, rospy.Time.now()
        msg.poses = [convert.pose_msg(c.x, c.y, c.yaw) for c in candidates]
        self.poses_pub.publish(msg)

    # --- diagnostics and shutdown ------------------------------------------------------------------------------------
    def _diagnose(self, stat):
        with self.lock:
            running, user = self.running, self.user
        if running:
            stat.summary(OK, f"approaching the user at ({user[0]:.2f}, {user[1]:.2f})")
        else:
            stat.summary(self.last_level, self.last)
        stat.add("Last approach", self.last)
        return stat

    def shutdown(self):
        self.cancel.set()
        self.diag.shutdown()
        publish_stop(self.cmd_pub)


def main():
    run(ApproachMeMapNode, "approach_me_map_node")
