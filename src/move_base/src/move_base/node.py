"""move_base node: the ROS 1 move_base interface around the ROS-free planners and state machine.

ROS Parameters: PARAMS below and move_base.move_base_core.PARAMS (``~``), navfn.PARAMS
(``~NavfnROS/``), trajectory_planner.PARAMS (``~TrajectoryPlannerROS/``), costmap_config.PARAMS
and SOURCE_PARAMS (``~global_costmap/``, ``~local_costmap/``), recovery.CLEAR_COSTMAP_PARAMS
(``~<recovery name>/``); all rendered in the README. A bad value is a fatal error naming it.

Actions:
    move_base (move_base_msgs/MoveBaseAction): goal = target pose; feedback = the robot's pose in the
        global costmap frame; every abort carries the reason as the status text.

Subscribers:
    move_base_simple/goal (geometry_msgs/PoseStamped): a goal without status tracking.
    odom (nav_msgs/Odometry): the robot's velocity, for the local planner.
    ~approach_target (geometry_msgs/PointStamped): where the person the robot is sent to stands
        (approach_me_map, while its goal runs): she is kept at TrajectoryPlannerROS/
        approach_person_distance instead of min_person_distance and is nobody to wait for, and she
        stands in the global costmap's proxemic layer while the tracker holds nobody there; it lapses
        APPROACH_TARGET_KEEP after the last message.

Publishers:
    cmd_vel (geometry_msgs/Twist): velocity commands at controller_frequency; zero on every stop.
    ~waiting_for (geometry_msgs/PointStamped, global frame): while the robot waits for people in its
        way (WAITING), where the nearest of them stands (a tracked person or a leg-height return the
        maps do not explain), at most twice a second: florence_locator looks at who it is.
    ~current_goal (geometry_msgs/PoseStamped), ~NavfnROS/plan (nav_msgs/Path),
    ~TrajectoryPlannerROS/global_plan and ~TrajectoryPlannerROS/local_plan (nav_msgs/Path),
    ~global_costmap/costmap, ~local_costmap/costmap (nav_msgs/OccupancyGrid) and their footprints.
    /diagnostics (diagnostic_msgs/DiagnosticArray, through diagnostic_updater): the current goal
        and its recoveries, the control rate achieved against controller_frequency, the costmaps'
        update ages.

Services:
    ~make_plan (nav_msgs/GetPlan), ~clear_costmaps (std_srvs/Empty),
    ~clear_unknown_space (std_srvs/Empty).
"""

import collections
import math
import threading

import actionlib
import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PointStamped, PoseStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionGoal, MoveBaseFeedback, MoveBaseResult
from nav_msgs.msg import Odometry, Path
from nav_msgs.srv import GetPlan, GetPlanResponse
from std_srvs.srv import Empty, EmptyResponse

from florence_common import pose as pose2d
from florence_common.params import Param, ParamError, ParamTable
from florence_common_ros import convert
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import publish_stop, read_params, run
from move_base import move_base_core, navfn
from move_base.costmap_2d import LETHAL_OBSTACLE
from move_base.costmap_ros import Costmap2DROS
from move_base.layers import footprint_cost
from move_base.local_planner import NO_VALID_TRAJECTORY_PEOPLE, LocalPlanner
from move_base.move_base_core import CLEARING, WAITING, MoveBaseCore
from move_base.navfn import NavfnPlanner, compute_potential, translate_costs
from move_base.people_layer import (
    GIVE_WAY_KEEP_OFF,
    GIVE_WAY_MAX_COST,
    GIVE_WAY_MIN_DISTANCE,
    RecentPoints,
    approach_exemption,
    blocked_plan_reason,
    give_way_cells,
    near_walks,
    walking_away,
)
from move_base.recovery import (
    CLEAR_COSTMAP_PARAMS,
    ClearCostmapRecovery,
    RotateRecovery,
    default_recovery_specs,
    footprint_collision_check,
)
from move_base.trajectory_planner import PlannerParams

LOG = "move_base: "
GLOBAL_PLANNERS = ("navfn/NavfnROS", "NavfnROS")
LOCAL_PLANNERS = ("base_local_planner/TrajectoryPlannerROS", "TrajectoryPlannerROS")
RECOVERY_TYPES = ("ClearCostmapRecovery", "RotateRecovery")  # with or without their package prefix
APPROACH_TARGET_KEEP = 1.5  # [s] an approach_target older than this lapses (approach_me_map sends it at 2 Hz)


def _recovery_specs_problem(specs):
    for spec in specs:
        if not isinstance(spec, dict) or "name" not in spec or "type" not in spec:
            return f"must be a list of {{name, type}}: entry {spec!r} needs a name and a type"
        if not str(spec["type"]).endswith(RECOVERY_TYPES):
            return (f"entry {spec['name']!r}: type {spec['type']!r} is not available "
                    "(clear_costmap_recovery/ClearCostmapRecovery, rotate_recovery/RotateRecovery)")
    return None


PARAMS = ParamTable(
    Param("base_global_planner", str, "navfn/NavfnROS", "the global planner (navfn is the only one)",
          choices=GLOBAL_PLANNERS),
    Param("base_local_planner", str, "base_local_planner/TrajectoryPlannerROS", "the local planner: trajectory "
          "rollout, or DWA with ~TrajectoryPlannerROS/dwa true (the only one)", choices=LOCAL_PLANNERS),
    Param("recovery_behaviors", list, None, "the recoveries in order, [{name, type}, ...]: "
          "clear_costmap_recovery/ClearCostmapRecovery (CLEAR_COSTMAP_PARAMS in the namespace ~name/) or "
          "rotate_recovery/RotateRecovery "
          "(unset: ROS's conservative_reset, rotate_recovery, aggressive_reset, rotate_recovery)", optional=True,
          check=_recovery_specs_problem),
)
"""The move_base node's own parameters (``~``); the state machine's are move_base_core.PARAMS."""


def in_namespace(namespace, read):
    """``read()``, its ParamError prefixed with ``namespace`` (the names in a table are relative to it)."""
    try:
        return read()
    except ParamError as exc:
        raise ParamError(f"in ~{namespace}/: {exc}") from None


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
    static map, or on a lethal cell of the static map itself (a wall, furniture) or of the
    keep-out map (a place the robot must not enter)."""
    if layered.rolling_window:
        return False
    if not layered.costmap.contains(x, y):
        return True
    for layer in (getattr(layered, "static", None), getattr(layered, "keepout", None)):
        if layer is not None and layer.grid is not None and layer.pose is None and \
                layer.grid.cost_at(x, y) == LETHAL_OBSTACLE:
            return True
    return False


def path_msg(poses, frame, stamp):
    """nav_msgs/Path of poses (N, 3) (x [m], y [m], yaw [rad]) in ``frame``."""
    msg = Path()
    msg.header.frame_id = frame
    msg.header.stamp = stamp
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    if len(poses) == 0:
        return msg
    quaternions = pose2d.yaw_to_quaternion(poses[:, 2]).reshape(-1, 4)  # one scipy call for the whole path
    for (x, y, _), (qx, qy, qz, qw) in zip(poses.tolist(), quaternions.tolist(), strict=True):
        p = PoseStamped()
        p.header = msg.header
        p.pose.position.x, p.pose.position.y = x, y
        p.pose.orientation.x, p.pose.orientation.y, p.pose.orientation.z, p.pose.orientation.w = qx, qy, qz, qw
        msg.poses.append(p)
    return msg


class ControllerAdapter:
    """The state machine's controller: the local planner on the local costmap, with the global plan
    moved into the local costmap's frame each cycle."""

    def __init__(self, node):
        self.node = node

    def set_plan(self, poses, giving_way=False):
        self.node.local_planner.set_plan(np.asarray(poses, dtype=float), giving_way)

    def compute_velocity(self, pose):
        node = self.node
        local = node.controller_costmap
        start = rospy.get_time()
        here = local.get_robot_pose()
        if here is None:
            return False, (0.0, 0.0, 0.0), "transform timeout: no robot pose in the local costmap frame"
        to_local = node.lookup_planar(local.global_frame, node.planner_costmap.global_frame)
        if to_local is None:
            return False, (0.0, 0.0, 0.0), (f"transform timeout: {node.planner_costmap.global_frame} -> "
                                            f"{local.global_frame}")
        # the local planner's stored copy: it prunes it as the robot advances (TrajectoryPlannerROS)
        plan_local = np.asarray(pose2d.compose(to_local, node.local_planner.global_plan)).reshape(-1, 3)
        still = None
        if node.local_planner.params.min_person_distance > 0.0:
            # leg-height returns the maps do not have, near the robot, seen in the last 1.5 s: people
            # the tracker may not know (remembered: the robot may have turned away from them)
            still = node.unmapped_near(pose, 2.5)
            still = pose2d.transform_points(to_local, still) if len(still) else still
        node.local_planner.pose_age = local.robot_pose_age + max(0.0, rospy.get_time() - start)
        # the people the global costmap still remembers (its keep_time: 8 s in the launch file against the
        # local 2 s), for the rule that the robot does not back up toward a person behind it
        remembered = None
        global_people = node.planner_costmap.layered.people
        if global_people is not None and node.local_planner.params.min_person_distance > 0.0:
            with node.planner_costmap.lock:
                remembered = np.asarray(global_people.current(rospy.get_time())[0], dtype=float).reshape(-1, 4)
            if len(remembered):
                remembered = np.column_stack([pose2d.transform_points(to_local, remembered[:, :2]),
                                              np.zeros((len(remembered), 2))])
        approached = node.approach_target(local.global_frame)
        with local.lock:
            if local.layered.people is not None:
                node.local_planner.set_people(local.layered.people.current(rospy.get_time())[0], still, remembered,
                                              approached)
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


class PeopleAdapter:
    """The state machine's view of people (Florence's waiting and giving way), from the global
    costmap: the tracked people of its proxemic layer, and what its sensors see at leg height where
    the map has nothing (a person the tracker does not know, standing close or out of the Kinect's
    view; or something that was moved)."""

    def __init__(self, node):
        self.node = node
        self.nearest = None  # (x, y) [m] of the last blocker named (_describe)

    def _people(self):
        """(P, 4) x, y [m], vx, vy [m/s] of the tracked people in the global frame now, and (P, 2)
        the heading each last walked on (NaN: none; ProxemicLayer.headings)."""
        layer = self.node.planner_costmap.layered.people
        if layer is None:
            return np.zeros((0, 4)), np.zeros((0, 2))
        with self.node.planner_costmap.lock:
            people, ids = layer.current(rospy.get_time())
            return people, layer.headings(ids)

    def _blockers(self, pose, radius, with_headings=False):
        """(B, 4) the tracked people and the unmapped leg-height returns (still) within ``radius``
        [m], and how many of them are tracked people (the first ones); ``with_headings``: also (B, 2)
        the heading each last walked on (NaN: none, and for every unmapped return)."""
        people, headings = self._people()
        still = self.node.unmapped_near(pose, radius)
        target = self.node.approach_target(self.node.planner_costmap.global_frame)
        if target is not None:  # the person the robot is sent to is nobody to wait for or give way to
            _, still, her = approach_exemption(people, still, target, 0.0, 0.0)
            if her >= 0:
                people, headings = np.delete(people, her, axis=0), np.delete(headings, her, axis=0)
        near = np.hypot(people[:, 0] - pose[0], people[:, 1] - pose[1]) <= radius
        rows = [people[near], np.column_stack([still, np.zeros((len(still), 2))])]
        blockers = np.concatenate(rows).reshape(-1, 4)
        if not with_headings:
            return blockers, len(rows[0])
        return blockers, len(rows[0]), np.concatenate([headings[near], np.full((len(still), 2), np.nan)])

    def _describe(self, pose, blockers, tracked):
        """Who the nearest of ``blockers`` is and where, in words ('' for nobody); kept as
        :attr:`nearest` ((x, y) [m] in the global frame, or None) for ``~waiting_for``."""
        self.nearest = None
        if not len(blockers):
            return ""
        d = np.hypot(blockers[:, 0] - pose[0], blockers[:, 1] - pose[1])
        i = int(np.argmin(d))
        self.nearest = (float(blockers[i, 0]), float(blockers[i, 1]))
        what = "a person" if i < tracked else "something the map does not have (a person?)"
        return f"{what} at ({blockers[i, 0]:.2f}, {blockers[i, 1]:.2f}), {d[i]:.2f} m away"

    def blocking(self, pose, goal, reason, waiting=False):
        """Why people stand in the way after a failed plan (``reason`` None: a plan exists on the
        maps alone, without what the sensors marked; people_layer.blocked_plan_reason) or control
        (the local planner kept its distance from a person, or a person or an unmapped obstacle is
        within 1.2 m), or ''. ``waiting``: the robot already waits for them."""
        blockers, tracked = self._blockers(pose, 1.2 if reason is not None else 3.0)
        near = self._describe(pose, blockers, tracked)
        if reason == NO_VALID_TRAJECTORY_PEOPLE:
            return f"{near or 'a person'} is nearer than min_person_distance on every way on"
        if reason is not None:
            return f"{near}: {reason}" if near else ""
        if not near and not waiting:
            return ""  # blocked_plan_reason's answer whatever the maps say: no plan on them needed
        costmap = self.node.planner_costmap
        with costmap.lock:
            free = costmap.layered.map_only()
            result = self.node.global_planner.make_plan(free, pose, goal, start_clearance=costmap.inscribed_radius)
        return blocked_plan_reason(near, result.ok, waiting)

    def clear(self, pose, poses):
        """Whether nobody is close in front: no tracked person within min_person_distance + 0.1 m
        and no leg-height return within min_person_distance of the robot, in the half-plane ahead
        along the plan ``poses`` (where it goes next), so that waiting ends with room to go on."""
        near = self.node.local_planner.params.min_person_distance
        blockers, tracked = self._blockers(pose, near + 0.1)
        if not len(blockers):
            return True
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        d_plan = np.hypot(poses[:, 0] - pose[0], poses[:, 1] - pose[1])
        ahead = np.nonzero(d_plan >= 0.3)[0]
        tx, ty = poses[ahead[0], :2] if len(ahead) else poses[-1, :2]
        ux, uy = tx - pose[0], ty - pose[1]
        rx, ry = blockers[:, 0] - pose[0], blockers[:, 1] - pose[1]
        d = np.hypot(rx, ry)
        reach = np.where(np.arange(len(blockers)) < tracked, near + 0.1, near)
        in_front = rx * ux + ry * uy > 0.0
        return not np.any((d < reach) & in_front)

    def give_way(self, pose):
        """A pose (x, y, yaw) out of the way of the people (and unmapped marks) within 2 m
        (people_layer.give_way_cells on a navfn potential from the robot over the global costmap),
        or None."""
        costmap = self.node.planner_costmap
        blockers, tracked, headings = self._blockers(pose, 2.0, with_headings=True)
        layer = costmap.layered.people
        if tracked and layer is not None and layer.follow_speed > 0.0:
            # nobody needs the robot out of the way of a person walking away from it (it follows them)
            away = walking_away(blockers[:tracked], pose[0], pose[1], layer.follow_speed)
            keep = np.concatenate([~away, np.ones(len(blockers) - tracked, dtype=bool)])
            blockers, headings = blockers[keep], headings[keep]
            tracked -= int(away.sum())
        if not len(blockers):
            return None
        with costmap.lock:
            grid = costmap.layered.costmap.copy()
        cell = grid.world_to_map(pose[0], pose[1])
        if cell is None:
            return None
        trav = translate_costs(grid.costs, self.node.global_planner.allow_unknown, cell)
        potential = compute_potential(trav, cell)
        potential = np.where(grid.costs < GIVE_WAY_MAX_COST, potential, np.inf)
        target = give_way_cells(potential, grid, pose[:2], blockers, GIVE_WAY_KEEP_OFF, GIVE_WAY_MIN_DISTANCE,
                                headings)
        if target is None:
            rospy.loginfo(LOG + "no place to give way to the people from (%.2f, %.2f)", pose[0], pose[1])
            return None
        rospy.loginfo(LOG + "giving way from (%.2f, %.2f) to (%.2f, %.2f): %d tracked people, %d unmapped points "
                      "within 2 m; %s", pose[0], pose[1], target[0], target[1], tracked, len(blockers) - tracked,
                      self._describe(pose, blockers, tracked))
        return target[0], target[1], math.atan2(target[1] - pose[1], target[0] - pose[0])

    def plan_to(self, start, pose):
        return self.node._plan(start, pose)


class MoveBaseNode:
    """The move_base node: reads its parameters, builds costmaps, planners and recoveries, then serves."""

    def __init__(self):
        self.node_params = read_params(PARAMS)
        self.params = read_params(move_base_core.PARAMS)
        self.global_planner = NavfnPlanner(**in_namespace("NavfnROS", lambda: read_params(navfn.PARAMS,
                                                                                          "~NavfnROS/")))
        tp = dict(rospy.get_param("~TrajectoryPlannerROS", {}) or {})  # a dict: ROS's old names are accepted too
        tp.setdefault("controller_frequency", self.params.controller_frequency)
        self.planner_params = in_namespace("TrajectoryPlannerROS", lambda: PlannerParams.from_dict(tp))

        # publishers before anything that calls back
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.goal_pub = rospy.Publisher("~current_goal", PoseStamped, queue_size=1, latch=True)
        self.plan_pub = rospy.Publisher("~NavfnROS/plan", Path, queue_size=1, latch=True)
        self.global_plan_pub = rospy.Publisher("~TrajectoryPlannerROS/global_plan", Path, queue_size=1)
        self.local_plan_pub = rospy.Publisher("~TrajectoryPlannerROS/local_plan", Path, queue_size=1)
        self.action_goal_pub = rospy.Publisher("move_base/goal", MoveBaseActionGoal, queue_size=1)
        self.waiting_for_pub = rospy.Publisher("~waiting_for", PointStamped, queue_size=1)
        self._waiting_for_sent = -math.inf  # [s] ROS time of the last ~waiting_for

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.planner_costmap = Costmap2DROS("global_costmap", self.tf_buffer)
        self.controller_costmap = Costmap2DROS("local_costmap", self.tf_buffer)
        local = self.controller_costmap
        self.local_planner = LocalPlanner(self.planner_params, local.footprint, local.inscribed_radius,
                                          local.circumscribed_radius, body=local.body)
        self.recoveries = self._load_recoveries()
        people = None
        if self.params.person_wait_timeout > 0.0:
            if self.planner_costmap.layered.people is None:
                rospy.logwarn(LOG + "person_wait_timeout is set but the global costmap has no people_topic: the "
                              "robot cannot tell when people stand in its way, and does not wait for them")
            else:
                people = PeopleAdapter(self)
        self.core = MoveBaseCore(self.params, self._plan_for_core, ControllerAdapter(self),
                                 self.recoveries, self._sensors_current, people)
        self.core_lock = threading.Lock()
        self.recoveries_run = 0  # since start
        self.goal_recoveries = 0  # in the current (or last) goal
        self.last_outcome = ("", "")  # (outcome, text) of the last goal
        # ROS times [s] of the latest control cycles: the rate achieved
        self.cycle_times = collections.deque(maxlen=max(5, math.ceil(2.0 * self.params.controller_frequency) + 1))

        self._velocity = (0.0, 0.0, 0.0)
        self._velocity_lock = threading.Lock()
        self.recent_still = RecentPoints(1.5)
        self._still_lock = threading.Lock()
        rospy.Subscriber("odom", Odometry, self._odom_cb, queue_size=1)
        self._approach_target = None  # (PointStamped, ROS time [s] received)
        self._approach_lock = threading.Lock()
        rospy.Subscriber("~approach_target", PointStamped, self._approach_target_cb, queue_size=1)

        self.planner_costmap.start()
        self.controller_costmap.start()
        if self.params.shutdown_costmaps:
            self.planner_costmap.stop()
            self.controller_costmap.stop()

        self.diagnostics = Diagnostics("move_base")
        self.diagnostics.add("Goal", self._diagnose_goal)
        self.diagnostics.add("Controller rate", self._diagnose_rate)
        self.diagnostics.add("Costmaps", self._diagnose_costmaps)

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
        specs = self.node_params.recovery_behaviors
        if specs is None:
            specs = default_recovery_specs(self.params.conservative_reset_dist,
                                           self.controller_costmap.circumscribed_radius,
                                           self.params.clearing_rotation_allowed)
        else:
            parsed = []
            for spec in specs:
                name, kind, reset = spec["name"], spec["type"], None
                if kind.endswith("ClearCostmapRecovery"):
                    reset = in_namespace(name, lambda name=name: read_params(CLEAR_COSTMAP_PARAMS, f"~{name}/"))
                    reset = reset.reset_distance
                parsed.append((name, kind, reset))
            specs = parsed
        costmaps = [self.planner_costmap, self.controller_costmap]
        # a turn on the spot keeps the robot's body clear, as the local planner's (LocalPlanner._sweep_is_free)
        check = footprint_collision_check(self._local_footprint_cost, self.controller_costmap.body)
        out = []
        for name, kind, reset in specs:
            if kind.endswith("ClearCostmapRecovery"):
                out.append(ClearCostmapRecovery(name, costmaps, reset))
            else:  # RotateRecovery (PARAMS' check)
                p = self.planner_params
                out.append(RotateRecovery(name, check, self.controller_costmap.get_robot_pose,
                                          acc_lim_th=p.acc_lim_theta, max_rotational_vel=p.max_vel_theta,
                                          min_in_place_rotational_vel=p.min_in_place_vel_theta))
        return out

    def unmapped_near(self, pose, radius):
        """(N, 2) [m] in the global frame: the leg-height returns the maps do not explain within
        ``radius`` of ``pose``, seen now or in the last 1.5 s (LayeredCostmap.unmapped_marks), less
        the legs of a person the robot follows (people_layer.walking_away: the local planner keeps
        them at min_person_distance as they walk on; their legs, seen along their last 1.5 s of
        walking, are not people standing still)."""
        costmap = self.planner_costmap
        now = rospy.get_time()
        with costmap.lock:
            seen = costmap.layered.unmapped_marks(pose[0], pose[1], max(radius, 2.5))
            people = costmap.layered.people
            followed = people.followed(now, pose[:2]) if people is not None else np.zeros((0, 4))
        with self._still_lock:
            self.recent_still.add(now, seen)
            pts = self.recent_still.get(now)
        pts = pts[np.hypot(pts[:, 0] - pose[0], pts[:, 1] - pose[1]) <= radius]
        if len(followed):
            pts = pts[~near_walks(pts, followed, people.trail_radius, self.recent_still.keep)]
        return pts

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

    def _approach_target_cb(self, msg):
        with self._approach_lock:
            self._approach_target = (msg, rospy.get_time())
        # she stands in the global costmap while announced, tracked or not (ProxemicLayer.sent_to)
        layer = self.planner_costmap.layered.people
        where = self.approach_target(self.planner_costmap.global_frame)
        if layer is not None and where is not None:
            with self.planner_costmap.lock:
                layer.sent_to(*where, rospy.get_time() + APPROACH_TARGET_KEEP)

    def approach_target(self, frame):
        """(x, y) [m] in ``frame`` of the person the robot is sent to (``~approach_target``), or None
        when nobody announced one within APPROACH_TARGET_KEEP, it is not finite or not transformable."""
        with self._approach_lock:
            held = self._approach_target
        if held is None or rospy.get_time() - held[1] > APPROACH_TARGET_KEEP:
            return None
        msg = held[0]
        xy = np.array([[msg.point.x, msg.point.y]], dtype=float)
        if not np.all(np.isfinite(xy)):
            rospy.logwarn_throttle(10.0, LOG + "approach_target is not finite: ignored")
            return None
        source = msg.header.frame_id or self.planner_costmap.global_frame
        if source != frame:
            tf = self.lookup_planar(frame, source, timeout=0.05)
            if tf is None:
                rospy.logwarn_throttle(10.0, LOG + f"approach_target's frame {source!r} cannot be transformed to "
                                       f"{frame!r}: ignored")
                return None
            xy = pose2d.transform_points(tf, xy)
        return float(xy[0, 0]), float(xy[0, 1])

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
        return convert.to_xyyaw(t)

    # --- diagnostics ----------------------------------------------------------------------------
    def _diagnose_goal(self, stat):
        with self.core_lock:
            state = self.core.state
            goal = self.core.g.goal if self.core.g is not None else None
            recovery = self.core.g.recovery if self.core.g is not None else None
            outcome, text = self.last_outcome
            goal_recoveries, total = self.goal_recoveries, self.recoveries_run
        if state is None:
            level, summary = OK, "no goal"
            if outcome == "aborted":
                level, summary = WARN, f"last goal aborted: {text}"
            elif outcome:
                summary = f"no goal (last {outcome})"
        else:
            level = WARN if state in (CLEARING, WAITING) else OK
            summary = f"{state} toward ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f} rad)"
            if state == WAITING:
                summary += f": {self.core.g.reasons.get(self.core.g.wait_trigger, '')}"
            if state == CLEARING and recovery is not None:
                summary += f": recovery {recovery.name}"
        stat.summary(level, summary)
        stat.add("State", state or "idle")
        stat.add("Last outcome", f"{outcome}: {text}" if outcome else "")
        stat.add("Recoveries in this goal", goal_recoveries)
        stat.add("Recoveries since start", total)
        return stat

    def _diagnose_rate(self, stat):
        wanted = self.params.controller_frequency
        with self.core_lock:
            active, times = self.core.active, list(self.cycle_times)
        achieved = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 2 and times[-1] > times[0] else None
        if not active:
            stat.summary(OK, "no goal: the control loop is idle")
        elif achieved is None:
            stat.summary(OK, "control loop starting")
        elif achieved < 0.9 * wanted:
            stat.summary(WARN, f"control loop at {achieved:.1f} Hz, below controller_frequency {wanted:.1f} Hz")
        else:
            stat.summary(OK, f"control loop at {achieved:.1f} Hz")
        stat.add("controller_frequency [Hz]", f"{wanted:.2f}")
        stat.add("Achieved [Hz]", "" if achieved is None else f"{achieved:.2f}")
        return stat

    def _diagnose_costmaps(self, stat):
        problems = []
        for costmap in (self.planner_costmap, self.controller_costmap):
            age = costmap.update_age()
            stat.add(f"{costmap.name} update age [s]", "never" if age is None else f"{age:.2f}")
            if not costmap.running or costmap.update_frequency <= 0.0:
                continue  # paused (shutdown_costmaps) or updated on request only
            if age is None:
                problems.append(f"{costmap.name}: no update yet (no robot pose?)")
            elif age > 2.0 / costmap.update_frequency + 0.5:
                problems.append(f"{costmap.name}: last update {age:.1f} s ago "
                                f"(update_frequency {costmap.update_frequency:.1f} Hz)")
        if problems:
            stat.summary(WARN, "; ".join(problems))
        else:
            stat.summary(OK, "costmaps up to date")
        return stat

    # --- planning -----------------------------------------------------------------------------
    def _plan(self, start, goal, tolerance=None, current=None):
        """navfn's plan from ``start`` to ``goal``; with ``current``, the plan being followed to the
        same goal, that plan's rest instead when the new plan goes another way and costs little
        less (navfn.keep_current_plan)."""
        costmap = self.planner_costmap
        with costmap.lock:
            result = self.global_planner.make_plan(costmap.costmap, start, goal, tolerance,
                                                   start_clearance=costmap.inscribed_radius)
            if result.ok and current is not None:
                people = costmap.layered.people
                around = [costmap.layered.unmapped_marks(start[0], start[1], 2.5)]  # a person untracked?
                if people is not None:
                    around.append(people.current(rospy.get_time())[0][:, :2])
                kept = navfn.keep_current_plan(costmap.costmap, current, result.poses, start[:2],
                                               self.params.replan_keep_ratio, self.params.replan_keep_margin,
                                               people=np.concatenate(around),
                                               allow_unknown=self.global_planner.allow_unknown,
                                               start_clearance=costmap.inscribed_radius)
                if kept is not None:
                    result = navfn.PlanResult(True, kept, "", result.potential)
            if not result.ok and costmap.layered.forget_unseen_people():
                # people remembered out of view (proxemic unseen_keep_time) may be gone: no plan with
                # them is no reason to wait or give up
                rospy.loginfo(LOG + "no plan round the people remembered out of view: forgotten, planning again")
                result = self.global_planner.make_plan(costmap.costmap, start, goal, tolerance,
                                                       start_clearance=costmap.inscribed_radius)
            if not result.ok:
                result.permanent = goal_is_hopeless(costmap.layered, goal[0], goal[1])
        return result

    def _plan_for_core(self, start, goal):
        lp = self.local_planner
        current = lp.global_plan
        hysteresis = self.params.replan_keep_ratio > 0.0 or self.params.replan_keep_margin > 0.0
        same_goal = (hysteresis and lp.stop_for_people and len(current) > 1  # not a plan out of people's way
                     and np.allclose(current[-1], goal, rtol=0.0, atol=1e-6))
        result = self._plan(start, goal, current=current.copy() if same_goal else None)
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
        goal = (p.x, p.y, convert.yaw_of(q))
        if frame == target:
            return goal
        try:
            t = self.tf_buffer.lookup_transform(target, frame, rospy.Time(0), rospy.Duration(1.0))
        except tf2_ros.TransformException as exc:
            return f"the goal's frame {frame!r} cannot be transformed to {target!r}: {exc}"
        return pose2d.compose(convert.to_xyyaw(t), goal)

    def _simple_goal_cb(self, msg):
        rospy.loginfo(LOG + "goal on move_base_simple/goal, passed to the action server")
        action_goal = MoveBaseActionGoal()
        action_goal.header.stamp = rospy.Time.now()
        action_goal.goal.target_pose = msg
        self.action_goal_pub.publish(action_goal)

    def publish_zero(self):
        self.cmd_pub.publish(Twist())

    def shutdown(self):
        """Last words: a zero velocity, so the base does not drive on with the last command."""
        publish_stop(self.cmd_pub)

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
            self.goal_recoveries = 0
            self.last_outcome = ("", "")
            self.cycle_times.clear()
        msg = convert.pose_stamped(*goal, self.planner_costmap.global_frame, rospy.Time.now())
        self.goal_pub.publish(msg)
        rospy.loginfo(LOG + "new goal (%.2f, %.2f, %.2f rad) in %s", goal[0], goal[1], goal[2], msg.header.frame_id)
        return None

    def _end(self, outcome, text):
        with self.core_lock:
            self.core.reset()
            self.last_outcome = (outcome, text)
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
        last_text = ""
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
                feedback.base_position = convert.pose_stamped(*here, self.planner_costmap.global_frame,
                                                              rospy.Time.now())
                self.server.publish_feedback(feedback)
            with self.core_lock:
                state_before = self.core.state
                result = self.core.cycle(now, here)
                self.cycle_times.append(now)
                if result.started_recovery:
                    self.recoveries_run += 1
                    self.goal_recoveries += 1
            if result.started_recovery:
                rospy.logwarn(LOG + "running recovery behaviour %s (%s)", result.started_recovery, result.text)
            elif state_before != self.core.state and self.core.state is not None:
                rospy.loginfo(LOG + "%s -> %s%s", state_before, self.core.state,
                              f": {result.text}" if result.text else "")
            elif self.core.state == WAITING and result.text.split(":")[0] != last_text.split(":", maxsplit=1)[0]:
                rospy.loginfo(LOG + "%s", result.text)  # waiting <-> giving way
            elif result.text.startswith(("sensor data is out of date", "transform timeout")):
                rospy.logwarn_throttle(5.0, LOG + "standing: %s", result.text)
            last_text = result.text
            if self.core.state == WAITING:
                self._publish_waiting_for(now)
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

    def _publish_waiting_for(self, now):
        """``~waiting_for``: where the nearest one the robot waits for stands, at most twice a second."""
        nearest = getattr(self.core.people, "nearest", None)
        if nearest is None or now - self._waiting_for_sent < 0.5:
            return
        msg = PointStamped()
        msg.header.stamp = rospy.Time.now()
        msg.header.frame_id = self.planner_costmap.global_frame
        msg.point.x, msg.point.y = nearest
        self.waiting_for_pub.publish(msg)
        self._waiting_for_sent = now

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
    run(MoveBaseNode, "move_base")
