"""move_base node: the ROS 1 move_base interface around the ROS-free planners and state machine.

ROS Parameters (ROS names and defaults; the seed's YAML files set several):
    ~base_global_planner (str, "navfn/NavfnROS"): the only global planner here.
    ~base_local_planner (str, "base_local_planner/TrajectoryPlannerROS"): the only local planner
        here (trajectory rollout, or DWA with ~TrajectoryPlannerROS/dwa true).
    ~planner_frequency (double, 0.0, Hz): replanning rate while controlling (0: plan on new goals and
        after failures only).
    ~planner_patience (double, 5.0, s): planning time before recovery behaviours run.
    ~controller_frequency (double, 20.0, Hz): control loop and velocity command rate (seed: 5.0).
    ~controller_patience (double, 15.0, s): time without a valid command before recoveries run.
    ~max_planning_retries (int, -1): failed plans before recoveries run (-1: planner_patience only).
    ~oscillation_timeout (double, 0.0, s): time allowed without moving oscillation_distance (0: off).
    ~oscillation_distance (double, 0.5, m): how far the robot must move to reset that clock.
    ~recovery_behavior_enabled (bool, true), ~clearing_rotation_allowed (bool, true).
    ~conservative_reset_dist (double, 3.0, m): side of the square kept by the conservative reset.
    ~shutdown_costmaps (bool, false): pause the costmaps while there is no goal.
    ~max_recovery_restarts (int, -1): Florence addition: how often the recovery list may start over
        after apparent progress before the goal is aborted (-1: no limit, as ROS).
    ~recovery_behaviors (list of {name, type}, ROS's default list): types
        clear_costmap_recovery/ClearCostmapRecovery (~<name>/reset_distance, default 3.0 m) and
        rotate_recovery/RotateRecovery.
    ~global_costmap/*, ~local_costmap/*: see move_base.costmap_ros.
    ~NavfnROS/allow_unknown (bool, true), ~NavfnROS/default_tolerance (double, 0.0, m),
        ~NavfnROS/planner_window_x, ~NavfnROS/planner_window_y (double, 0.0, m),
        ~NavfnROS/visualize_potential (bool, false).
    ~TrajectoryPlannerROS/*: see move_base.trajectory_planner.PlannerParams.

Actions:
    move_base (move_base_msgs/MoveBaseAction): goal = target pose; feedback = the robot's pose in the
        global costmap frame; every abort carries the reason as the status text.

Subscribers:
    move_base_simple/goal (geometry_msgs/PoseStamped): a goal without status tracking.
    odom (nav_msgs/Odometry): the robot's velocity, for the local planner.

Publishers:
    cmd_vel (geometry_msgs/Twist): velocity commands at controller_frequency; zero on every stop.
    ~current_goal (geometry_msgs/PoseStamped), ~NavfnROS/plan (nav_msgs/Path),
    ~TrajectoryPlannerROS/global_plan and ~TrajectoryPlannerROS/local_plan (nav_msgs/Path),
    ~global_costmap/costmap, ~local_costmap/costmap (nav_msgs/OccupancyGrid) and their footprints.

Services:
    ~make_plan (nav_msgs/GetPlan), ~clear_costmaps (std_srvs/Empty),
    ~clear_unknown_space (std_srvs/Empty).
"""

import math
import threading

import actionlib
import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionGoal, MoveBaseFeedback, MoveBaseResult
from nav_msgs.msg import Odometry, Path
from nav_msgs.srv import GetPlan, GetPlanResponse
from std_srvs.srv import Empty, EmptyResponse

from move_base.costmap_2d import LETHAL_OBSTACLE
from move_base.costmap_ros import Costmap2DROS, pose_to_xyyaw, yaw_of
from move_base.layers import footprint_cost
from move_base.local_planner import LocalPlanner
from move_base.move_base_core import MoveBaseCore, MoveBaseParams
from move_base.navfn import NavfnPlanner
from move_base.recovery import ClearCostmapRecovery, RotateRecovery, default_recovery_specs, footprint_collision_check
from move_base.trajectory_planner import PlannerParams

LOG = "move_base: "
GLOBAL_PLANNERS = ("navfn/NavfnROS", "NavfnROS")
LOCAL_PLANNERS = ("base_local_planner/TrajectoryPlannerROS", "TrajectoryPlannerROS")


def quaternion_problem(q):
    """Why quaternion ``q`` cannot be a goal orientation, or '' when it can (ROS isQuaternionValid,
    stricter about the norm: a client's quaternion may differ from unit length by rounding only)."""
    values = np.array([q.x, q.y, q.z, q.w], dtype=float)
    if not np.all(np.isfinite(values)):
        return "its orientation has a non-finite component"
    norm = float(np.linalg.norm(values))
    if norm < 1e-6:
        return "its orientation is a zero quaternion"
    if abs(norm - 1.0) > 1e-2:
        return f"its orientation is not a unit quaternion (norm {norm:.3f})"
    x, y, _z, _w = values / norm
    # the rotated z axis must stay vertical: a goal is a heading on the floor
    up_z = 1.0 - 2.0 * (x * x + y * y)
    if abs(up_z - 1.0) > 1e-3:
        return "its orientation is not a rotation about the vertical axis"
    return ""


def goal_is_hopeless(layered, x, y):
    """True when no recovery can make (x, y) [m] reachable: off a global costmap that covers the
    static map, or on a lethal cell of the static map itself (a wall, furniture)."""
    if layered.rolling_window:
        return False
    if not layered.costmap.contains(x, y):
        return True
    static = getattr(layered, "static", None)
    if static is None or static.grid is None:
        return False
    return static.grid.cost_at(x, y) == LETHAL_OBSTACLE


def apply_transform(xyyaw, poses):
    """Poses (N, 3) through the planar transform (x, y, yaw)."""
    x, y, yaw = xyyaw
    c, s = math.cos(yaw), math.sin(yaw)
    out = np.empty_like(poses)
    out[:, 0] = x + c * poses[:, 0] - s * poses[:, 1]
    out[:, 1] = y + s * poses[:, 0] + c * poses[:, 1]
    out[:, 2] = poses[:, 2] + yaw
    return out


def path_msg(poses, frame, stamp):
    msg = Path()
    msg.header.frame_id = frame
    msg.header.stamp = stamp
    for x, y, yaw in poses:
        p = PoseStamped()
        p.header = msg.header
        p.pose.position.x, p.pose.position.y = float(x), float(y)
        p.pose.orientation.z, p.pose.orientation.w = math.sin(yaw / 2.0), math.cos(yaw / 2.0)
        msg.poses.append(p)
    return msg


class ControllerAdapter:
    """The state machine's controller: the local planner on the local costmap, with the global plan
    moved into the local costmap's frame each cycle."""

    def __init__(self, node):
        self.node = node

    def set_plan(self, poses):
        self.node.local_planner.set_plan(np.asarray(poses, dtype=float))

    def compute_velocity(self, pose):
        node = self.node
        local = node.controller_costmap
        here = local.get_robot_pose()
        if here is None:
            return False, (0.0, 0.0, 0.0), "transform timeout: no robot pose in the local costmap frame"
        to_local = node.lookup_planar(local.global_frame, node.planner_costmap.global_frame)
        if to_local is None:
            return False, (0.0, 0.0, 0.0), (f"transform timeout: {node.planner_costmap.global_frame} -> "
                                            f"{local.global_frame}")
        # the local planner's stored copy: it prunes it as the robot advances (TrajectoryPlannerROS)
        plan_local = apply_transform(to_local, node.local_planner.global_plan)
        with local.lock:
            ok, cmd, reason = node.local_planner.compute_velocity(local.costmap, here, node.robot_velocity(),
                                                                  plan_local)
        stamp = rospy.Time.now()
        node.global_plan_pub.publish(path_msg(plan_local, local.global_frame, stamp))
        traj = getattr(node.local_planner, "local_plan", None)
        if traj is not None and len(traj):
            node.local_plan_pub.publish(path_msg(np.asarray(traj), local.global_frame, stamp))
        return ok, cmd, reason

    def is_goal_reached(self):
        return self.node.local_planner.is_goal_reached()


class MoveBaseNode:
    """The move_base node: reads its parameters, builds costmaps, planners and recoveries, then serves."""

    def __init__(self):
        gp = rospy.get_param("~base_global_planner", "navfn/NavfnROS")
        lp = rospy.get_param("~base_local_planner", "base_local_planner/TrajectoryPlannerROS")
        if gp not in GLOBAL_PLANNERS:
            raise ValueError(f"~base_global_planner {gp!r} is not available (only navfn/NavfnROS)")
        if lp not in LOCAL_PLANNERS:
            raise ValueError(f"~base_local_planner {lp!r} is not available (only "
                             "base_local_planner/TrajectoryPlannerROS, with dwa true for DWA)")
        self.params = MoveBaseParams(
            planner_frequency=float(rospy.get_param("~planner_frequency", 0.0)),
            planner_patience=float(rospy.get_param("~planner_patience", 5.0)),
            controller_frequency=float(rospy.get_param("~controller_frequency", 20.0)),
            controller_patience=float(rospy.get_param("~controller_patience", 15.0)),
            max_planning_retries=int(rospy.get_param("~max_planning_retries", -1)),
            oscillation_timeout=float(rospy.get_param("~oscillation_timeout", 0.0)),
            oscillation_distance=float(rospy.get_param("~oscillation_distance", 0.5)),
            recovery_behavior_enabled=bool(rospy.get_param("~recovery_behavior_enabled", True)),
            clearing_rotation_allowed=bool(rospy.get_param("~clearing_rotation_allowed", True)),
            conservative_reset_dist=float(rospy.get_param("~conservative_reset_dist", 3.0)),
            shutdown_costmaps=bool(rospy.get_param("~shutdown_costmaps", False)),
            max_recovery_restarts=int(rospy.get_param("~max_recovery_restarts", -1)),
        ).validate()
        navfn = rospy.get_param("~NavfnROS", {}) or {}
        self.global_planner = NavfnPlanner(
            allow_unknown=bool(navfn.get("allow_unknown", True)),
            default_tolerance=float(navfn.get("default_tolerance", 0.0)),
            planner_window_x=float(navfn.get("planner_window_x", 0.0)),
            planner_window_y=float(navfn.get("planner_window_y", 0.0)),
            visualize_potential=bool(navfn.get("visualize_potential", False)),
        )
        tp = dict(rospy.get_param("~TrajectoryPlannerROS", {}) or {})
        tp.setdefault("controller_frequency", self.params.controller_frequency)
        self.planner_params = PlannerParams.from_dict(tp)

        # publishers before anything that calls back
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.goal_pub = rospy.Publisher("~current_goal", PoseStamped, queue_size=1, latch=True)
        self.plan_pub = rospy.Publisher("~NavfnROS/plan", Path, queue_size=1, latch=True)
        self.global_plan_pub = rospy.Publisher("~TrajectoryPlannerROS/global_plan", Path, queue_size=1)
        self.local_plan_pub = rospy.Publisher("~TrajectoryPlannerROS/local_plan", Path, queue_size=1)
        self.action_goal_pub = rospy.Publisher("move_base/goal", MoveBaseActionGoal, queue_size=1)

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.planner_costmap = Costmap2DROS("global_costmap", self.tf_buffer)
        self.controller_costmap = Costmap2DROS("local_costmap", self.tf_buffer)
        fp = self.controller_costmap.footprint
        self.local_planner = LocalPlanner(self.planner_params, fp, self.controller_costmap.inscribed_radius,
                                          self.controller_costmap.circumscribed_radius)
        self.recoveries = self._load_recoveries()
        self.core = MoveBaseCore(self.params, self._plan_for_core, ControllerAdapter(self),
                                 self.recoveries, self._sensors_current)
        self.core_lock = threading.Lock()

        self._velocity = (0.0, 0.0, 0.0)
        self._velocity_lock = threading.Lock()
        rospy.Subscriber("odom", Odometry, self._odom_cb, queue_size=1)

        self.planner_costmap.start()
        self.controller_costmap.start()
        if self.params.shutdown_costmaps:
            self.planner_costmap.stop()
            self.controller_costmap.stop()

        rospy.Service("~make_plan", GetPlan, self._make_plan_srv)
        rospy.Service("~clear_costmaps", Empty, self._clear_costmaps_srv)
        rospy.Service("~clear_unknown_space", Empty, self._clear_unknown_srv)
        self.server = actionlib.SimpleActionServer("move_base", MoveBaseAction, execute_cb=self._execute,
                                                   auto_start=False)
        self.server.register_preempt_callback(self._preempt_cb)
        rospy.Subscriber("move_base_simple/goal", PoseStamped, self._simple_goal_cb, queue_size=1)
        self.server.start()
        rospy.loginfo(LOG + "ready: global costmap in %s, local costmap in %s, controller at %.1f Hz",
                      self.planner_costmap.global_frame, self.controller_costmap.global_frame,
                      self.params.controller_frequency)

    # --- set-up helpers -----------------------------------------------------------------------
    def _load_recoveries(self):
        specs = rospy.get_param("~recovery_behaviors", None)
        if specs is None:
            specs = default_recovery_specs(self.params.conservative_reset_dist,
                                           self.controller_costmap.circumscribed_radius,
                                           self.params.clearing_rotation_allowed)
        else:
            if not isinstance(specs, list):
                raise ValueError("~recovery_behaviors must be a list of {name, type}")
            parsed = []
            for spec in specs:
                if not isinstance(spec, dict) or "name" not in spec or "type" not in spec:
                    raise ValueError(f"~recovery_behaviors entry {spec!r} needs a name and a type")
                reset = rospy.get_param(f"~{spec['name']}/reset_distance", 3.0)
                parsed.append((spec["name"], spec["type"], float(reset)))
            specs = parsed
        costmaps = [self.planner_costmap, self.controller_costmap]
        check = footprint_collision_check(self._local_footprint_cost, self.controller_costmap.footprint)
        out = []
        for name, kind, reset in specs:
            if kind.endswith("ClearCostmapRecovery"):
                out.append(ClearCostmapRecovery(name, costmaps, reset))
            elif kind.endswith("RotateRecovery"):
                p = self.planner_params
                out.append(RotateRecovery(name, check, self.controller_costmap.get_robot_pose,
                                          acc_lim_th=p.acc_lim_theta, max_rotational_vel=p.max_vel_theta,
                                          min_in_place_rotational_vel=p.min_in_place_vel_theta))
            else:
                raise ValueError(f"~recovery_behaviors: type {kind!r} of {name!r} is not available "
                                 "(ClearCostmapRecovery, RotateRecovery)")
        return out

    def _local_footprint_cost(self, points):
        local = self.controller_costmap
        with local.lock:
            return footprint_cost(local.costmap, points)

    def _sensors_current(self):
        ok = self.controller_costmap.is_current() and self.planner_costmap.is_current()
        if ok:
            return True, ""
        stale = self.controller_costmap.stale_sources() + self.planner_costmap.stale_sources()
        return False, "; ".join(stale) or "an observation source is stale"

    def _odom_cb(self, msg):
        t = msg.twist.twist
        with self._velocity_lock:
            self._velocity = (t.linear.x, t.linear.y, t.angular.z)

    def robot_velocity(self):
        with self._velocity_lock:
            return self._velocity

    def lookup_planar(self, target, source, timeout=0.2):
        """The planar transform (x, y, yaw) taking poses in ``source`` into ``target``, or None."""
        try:
            t = self.tf_buffer.lookup_transform(target, source, rospy.Time(0), rospy.Duration(timeout))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException,
                tf2_ros.TransformException):
            return None
        return pose_to_xyyaw(t)

    # --- planning -----------------------------------------------------------------------------
    def _plan(self, start, goal, tolerance=None):
        costmap = self.planner_costmap
        with costmap.lock:
            result = self.global_planner.make_plan(costmap.costmap, start, goal, tolerance)
            if not result.ok:
                result.permanent = goal_is_hopeless(costmap.layered, goal[0], goal[1])
        return result

    def _plan_for_core(self, start, goal):
        result = self._plan(start, goal)
        if result.ok:
            self.plan_pub.publish(path_msg(result.poses, self.planner_costmap.global_frame, rospy.Time.now()))
        return result

    def _make_plan_srv(self, req):
        frame = self.planner_costmap.global_frame
        goal = self._pose_in_global(req.goal)
        if isinstance(goal, str):
            rospy.logwarn(LOG + "make_plan: %s", goal)
            return GetPlanResponse()
        if req.start.header.frame_id:
            start = self._pose_in_global(req.start)
            if isinstance(start, str):
                rospy.logwarn(LOG + "make_plan: %s", start)
                return GetPlanResponse()
        else:
            start = self.planner_costmap.get_robot_pose()
            if start is None:
                rospy.logwarn(LOG + "make_plan: no robot pose and no start given")
                return GetPlanResponse()
        result = self._plan(start, goal, tolerance=max(0.0, req.tolerance) if req.tolerance > 0 else None)
        response = GetPlanResponse()
        if result.ok:
            response.plan = path_msg(result.poses, frame, rospy.Time.now())
        else:
            rospy.logwarn(LOG + "make_plan: %s", result.reason)
            response.plan.header.frame_id = frame
        return response

    def _clear_costmaps_srv(self, _req):
        for costmap in (self.planner_costmap, self.controller_costmap):
            costmap.reset_layers()
        rospy.loginfo(LOG + "costmaps cleared on request")
        return EmptyResponse()

    def _clear_unknown_srv(self, _req):
        size = 2.0 * self.controller_costmap.circumscribed_radius * 2.0
        for costmap in (self.planner_costmap, self.controller_costmap):
            here = costmap.get_robot_pose()
            if here is not None:
                costmap.clear_unknown_around(here[0], here[1], size)
        return EmptyResponse()

    # --- goals --------------------------------------------------------------------------------
    def _pose_in_global(self, pose_stamped):
        """(x, y, yaw) of a PoseStamped in the global costmap frame, or a string saying why not."""
        p, q = pose_stamped.pose.position, pose_stamped.pose.orientation
        if not all(math.isfinite(v) for v in (p.x, p.y, p.z)):
            return f"the goal position ({p.x}, {p.y}, {p.z}) is not finite"
        problem = quaternion_problem(q)
        if problem:
            return f"the goal is invalid: {problem}"
        frame = pose_stamped.header.frame_id.lstrip("/")
        if not frame:
            return "the goal has no frame_id"
        target = self.planner_costmap.global_frame
        if frame == target:
            return p.x, p.y, yaw_of(q)
        try:
            t = self.tf_buffer.lookup_transform(target, frame, rospy.Time(0), rospy.Duration(1.0))
        except tf2_ros.TransformException as exc:
            return f"the goal's frame {frame!r} cannot be transformed to {target!r}: {exc}"
        x, y, yaw = pose_to_xyyaw(t)
        c, s = math.cos(yaw), math.sin(yaw)
        return x + c * p.x - s * p.y, y + s * p.x + c * p.y, yaw + yaw_of(q)

    def _simple_goal_cb(self, msg):
        rospy.loginfo(LOG + "goal on move_base_simple/goal, passed to the action server")
        action_goal = MoveBaseActionGoal()
        action_goal.header.stamp = rospy.Time.now()
        action_goal.goal.target_pose = msg
        self.action_goal_pub.publish(action_goal)

    def publish_zero(self):
        self.cmd_pub.publish(Twist())

    def _preempt_cb(self):
        # stop at once on cancel; the control loop ends the goal on its next turn
        self.publish_zero()

    def _start_goal(self, target_pose):
        goal = self._pose_in_global(target_pose)
        if isinstance(goal, str):
            return goal
        if self.params.shutdown_costmaps:
            self.planner_costmap.start()
            self.controller_costmap.start()
        here = self.planner_costmap.get_robot_pose()
        with self.core_lock:
            self.core.set_goal(goal, rospy.get_time(), here)
        msg = PoseStamped()
        msg.header.frame_id = self.planner_costmap.global_frame
        msg.header.stamp = rospy.Time.now()
        msg.pose.position.x, msg.pose.position.y = goal[0], goal[1]
        msg.pose.orientation.z, msg.pose.orientation.w = math.sin(goal[2] / 2.0), math.cos(goal[2] / 2.0)
        self.goal_pub.publish(msg)
        rospy.loginfo(LOG + "new goal (%.2f, %.2f, %.2f rad) in %s", goal[0], goal[1], goal[2], msg.header.frame_id)
        return None

    def _end(self, outcome, text):
        with self.core_lock:
            self.core.reset()
        self.publish_zero()
        if self.params.shutdown_costmaps:
            self.planner_costmap.stop()
            self.controller_costmap.stop()
        if outcome == "succeeded":
            rospy.loginfo(LOG + "goal reached")
            self.server.set_succeeded(MoveBaseResult(), text)
        elif outcome == "preempted":
            rospy.loginfo(LOG + "goal cancelled")
            self.server.set_preempted(MoveBaseResult(), text)
        else:
            rospy.logwarn(LOG + "goal aborted: %s", text)
            self.server.set_aborted(MoveBaseResult(), text)

    def _execute(self, goal):
        problem = self._start_goal(goal.target_pose)
        if problem:
            self._end("aborted", f"Aborting on goal because {problem}")
            return
        period = 1.0 / self.params.controller_frequency
        next_time = rospy.get_time()
        while not rospy.is_shutdown():
            if self.server.is_preempt_requested():
                if self.server.is_new_goal_available():
                    new_goal = self.server.accept_new_goal()
                    problem = self._start_goal(new_goal.target_pose)
                    if problem:
                        self._end("aborted", f"Aborting on goal because {problem}")
                        return
                    continue
                self._end("preempted", "Goal cancelled.")
                return
            now = rospy.get_time()
            here = self.planner_costmap.get_robot_pose()
            if here is not None:
                feedback = MoveBaseFeedback()
                feedback.base_position.header.frame_id = self.planner_costmap.global_frame
                feedback.base_position.header.stamp = rospy.Time.now()
                feedback.base_position.pose.position.x, feedback.base_position.pose.position.y = here[0], here[1]
                feedback.base_position.pose.orientation.z = math.sin(here[2] / 2.0)
                feedback.base_position.pose.orientation.w = math.cos(here[2] / 2.0)
                self.server.publish_feedback(feedback)
            with self.core_lock:
                state_before = self.core.state
                result = self.core.cycle(now, here)
            if result.started_recovery:
                rospy.logwarn(LOG + "running recovery behaviour %s (%s)", result.started_recovery, result.text)
            elif state_before != self.core.state and self.core.state is not None:
                rospy.loginfo(LOG + "%s -> %s%s", state_before, self.core.state,
                              f": {result.text}" if result.text else "")
            if result.outcome:
                self._end(result.outcome, result.text)
                return
            if result.cmd is not None and not self.server.is_preempt_requested():
                cmd = Twist()
                cmd.linear.x, cmd.linear.y, cmd.angular.z = result.cmd
                self.cmd_pub.publish(cmd)
            next_time += period
            if not self._sleep_until(next_time):
                break
            if rospy.get_time() - next_time > period:  # fell behind (a slow cycle): don't try to catch up
                rospy.logwarn_throttle(10.0, LOG + "control loop missed its rate of %.1f Hz",
                                       self.params.controller_frequency)
                next_time = rospy.get_time()
        self._end("aborted", "move_base is shutting down")

    def _sleep_until(self, when):
        """Sleep on ROS time until ``when`` [s], waking early on a cancel; False on shutdown."""
        try:
            while not rospy.is_shutdown():
                left = when - rospy.get_time()
                if left <= 0.0 or self.server.is_preempt_requested():
                    return True
                rospy.sleep(min(left, 0.02))
        except rospy.ROSInterruptException:
            return False
        except rospy.ROSTimeMovedBackwardsException:
            return True
        return False


def main():
    rospy.init_node("move_base")
    try:
        MoveBaseNode()
    except ValueError as exc:
        rospy.logfatal(LOG + "%s", exc)
        raise SystemExit(1) from None
    rospy.spin()
