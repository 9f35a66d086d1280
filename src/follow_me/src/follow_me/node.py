"""follow_me_node: the FollowMe enabler (seed 4.1, Table 14), an actionlib server on
florence_common_ros.behaviour.Behaviour.

ROS Parameters: PARAMS below, and the gains of follow_me.law.GAINS (~k_distance ..., also served by
dynamic_reconfigure: cfg/FollowMe.cfg); both tables rendered in the README.

Action server follow_me (follow_me/FollowMe.action): the goal's (x, y), in ~base_frame, picks the
tracked person nearest to it (none within ~acquire_radius: ABORTED at once, with the reason); zero
max_lin_speed, max_ang_speed, desired_follow_distance take ~default_*; feedback (x, y) of the
person in ~base_frame every control cycle; result (x, y) when it ends. A person unseen for
~lost_timeout after a search: ABORTED "person lost". Cancel or a new goal: a zero command at once,
PREEMPTED.

Obstacles (~sources, as collision_monitor's: config/sources.yaml): the law steers at the person's
trail and knows no walls; where the collision monitor would stop its command because of something
beside the robot (a door jamb it grazes), the command is steered clear first
(collision_monitor.monitor.steer_clear, by the monitor's own rule: the nearest turn rate, within
~steer_limit of the law's, that passes at speed, or a turn on the spot away from it). What slows the
robot ahead (the person, a wall) is left to the law and the monitor.

ROS Subscribers:
    tracked_users (user_tracker_ni/TrackedUsers): people with persistent ids and positions (the
        launch files remap it to filtered_tracked_users).
    <topic of each source> (sensor_msgs/LaserScan, or a depth image with its camera_info): obstacles,
        only while a goal runs.

ROS Publishers:
    cmd_vel (geometry_msgs/Twist): while a goal runs (the launch files remap it to
        cmd_vel_mux/input/follow_me); one zero command when it ends.
    ~state (std_msgs/String): idle, or what the robot does (following, searching).
    /diagnostics: the goal, the person, the tracker's input.
"""

import numpy as np
import rospy
from collision_monitor.monitor import CLEAR, SLOW, TURN, MonitorConfig, steer_clear
from collision_monitor.obstacles import parse_sources
from collision_monitor.sources import ScanSources

from florence_common import pose as pose2d
from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.behaviour import aborted
from florence_common_ros.node import read_params, run
from florence_common_ros.people import PersonBehaviour
from follow_me.cfg import FollowMeConfig
from follow_me.law import FOLLOWING, GAINS, Follower, Limits
from follow_me.msg import FollowMeAction, FollowMeFeedback, FollowMeResult
from user_tracker_ni.msg import TrackedUsers

LOG = "follow_me: "
PARAMS = ParamTable(
    Param("rate", float, 10.0, "control cycles per second (feedback with each)", unit="Hz", gt=0, le=50),
    Param("base_frame", FRAME, "base_link", "the robot frame of the goal, the feedback and the result"),
    Param("acquire_radius", float, 0.6, "the goal's (x, y) picks the tracked person within this of it", unit="m",
          gt=0),
    Param("tracker_timeout", float, 1.0, "a goal needs a tracked_users message this recent", unit="s", gt=0),
    Param("acquire_wait", float, 0.5, "how long a goal waits for the tracker's next messages when the latest has "
          "nobody near (x, y) (a track that flickered)", unit="s", ge=0, le=5),
    Param("default_max_lin_speed", float, 0.5, "max_lin_speed of a goal that leaves it 0 (the Create's top speed)",
          unit="m/s", gt=0, le=0.5),
    Param("default_max_ang_speed", float, 1.5, "max_ang_speed of a goal that leaves it 0", unit="rad/s", gt=0, le=3),
    Param("default_follow_distance", float, 1.0, "desired_follow_distance of a goal that leaves it 0 (personal "
          "space: 0.45-1.2 m)", unit="m", gt=0),
    Param("robot_radius", float, 0.18, "the robot's radius; with ~person_radius, the nearest a followed person may "
          "be asked to be", unit="m", gt=0),
    Param("person_radius", float, 0.25, "a person's radius", unit="m", gt=0),
    Param("lost_grace", float, 0.5, "a person unseen this long is searched for", unit="s", gt=0),
    Param("lost_timeout", float, 10.0, "a person unseen this long (searching) ends the goal ABORTED", unit="s", gt=0),
    Param("reacquire_radius", float, 0.7, "a new track this near where the person was expected is taken for them",
          unit="m", gt=0),
    Param("reacquire_growth", float, 0.3, "how fast that radius grows once the person has been unseen for more than "
          "1 s (how far they may have walked on out of view: an elderly person's pace)", unit="m/s", ge=0, le=1.5),
    Param("reacquire_max_radius", float, 2.0, "the largest it grows to", unit="m", gt=0),
    Param("sources", list, None, "the obstacle sensors, as collision_monitor's ~sources (config/sources.yaml); "
          "unset: no steering clear", optional=True),
    Param("steer_limit", float, 0.6, "largest change of the law's turn rate that steers a command clear of "
          "something beside the robot, and the turn rate on the spot when no arc passes (0: never)", unit="rad/s",
          ge=0, le=1.5),
    Param("trail_clearance", float, 0.3, "with ~sources: the straight way to the point steered to on the person's "
          "trail keeps this from what the robot sees (its centre to a point; or no nearer than it is), else it steers "
          "to a nearer point on the trail (through a doorway's middle, as the person went, not past its jamb)",
          unit="m", gt=0, le=1.0),
    Param("stop_distance", float, MonitorConfig.stop_distance, "the collision monitor's: least clearance a "
          "steered command's path keeps (the footprint: a circle of ~robot_radius)", unit="m", gt=0),
)


class FollowMeNode(PersonBehaviour):
    def __init__(self):
        p = read_params(PARAMS)
        super().__init__("follow_me", FollowMeAction, p, GAINS, FollowMeConfig, TrackedUsers, "FollowMe", LOG)
        self.last_step = None
        specs = parse_sources(p.sources) if p.sources is not None and p.steer_limit > 0 else []
        # a depth source at 2 frames a second, as approach_me takes it: its points only steer
        # subscribed during goals only (PersonBehaviour)
        self.obstacles = ScanSources(specs, "odom", self.tf_buffer, log_prefix=LOG, depth_period=0.5,
                                     subscribe=False) if specs else None
        self.monitor = MonitorConfig(robot_radius=p.robot_radius, stop_distance=p.stop_distance)
        self.steered = 0  # control cycles whose command was steered clear
        self.start()

    # --- the goal ----------------------------------------------------------------------------------
    def limits(self, goal):
        """(Limits, None) after defaults, or (None, why the goal is refused)."""
        p = self.params
        why = self.check_goal(goal, ("x", "y", "max_lin_speed", "max_ang_speed", "desired_follow_distance"),
                              ("max_lin_speed", "max_ang_speed", "desired_follow_distance"))
        if why:
            return None, why
        limits = Limits(min(goal.max_lin_speed or p.default_max_lin_speed, p.default_max_lin_speed),
                        goal.max_ang_speed or p.default_max_ang_speed,
                        goal.desired_follow_distance or p.default_follow_distance)
        nearest = p.robot_radius + p.person_radius
        if limits.desired_distance < nearest:
            return None, (f"bad goal: desired_follow_distance {limits.desired_distance:.2f} m is below the robot's "
                          f"radius plus a person's ({nearest:.2f} m)")
        return limits, None

    def begin(self, goal):
        p = self.params
        limits, why = self.limits(goal)
        if why:
            return why
        why = self.attend(goal, lambda person, robot, frame: Follower(self.gains, limits, p.rate, p.lost_grace,
                                                                       p.lost_timeout, clearance=p.trail_clearance),
                          reacquire_growth=p.reacquire_growth, reacquire_max_radius=p.reacquire_max_radius)
        if why:
            return why
        self.last_step = None
        rospy.loginfo(LOG + "following person %d at (%.2f, %.2f) in %s; %.2f m/s, %.2f rad/s, %.2f m",
                      self.person.pid, *self.person.xy, self.frame, limits.max_lin_speed, limits.max_ang_speed,
                      limits.desired_distance)
        return None

    def step(self, goal):
        person = self.take_reports()
        robot = self.robot_pose()
        if robot is None:
            return None
        # the tracker's stamp and the robot's clock are one ROS time
        now = rospy.get_time()
        points, padding = self._points()
        out = self.controller.step(now, robot, person, points)
        if self.controller.lost:
            return aborted(f"person lost: {person.pid} unseen for {person.unseen_for(now):.1f} s "
                           f"(searched where they were last seen)", self.result())
        self.last_step = out
        v, w, text = out.v, out.w, out.text
        if points is not None and out.mode == FOLLOWING and v > 0:
            v, w, text = self._steer(robot, v, w, text, points, padding)
        self.drive(v, w, text)
        self.server.publish_feedback(FollowMeFeedback(*out.person))
        return None

    def _points(self):
        """(What the obstacle sources see [N, 2] in the tracker's frame, their padding), or (None, None)."""
        if self.obstacles is None:
            return None, None
        points, padding = self.obstacles.points()
        if not len(points):
            return None, None
        if self.frame != "odom":
            m, _ = self.people.robot_pose(self.frame, "odom")  # odom in the tracker's frame
            if m is None:
                return None, None
            return pose2d.transform_points(m, points[:, :2]), padding
        return np.asarray(points[:, :2]), padding

    def _steer(self, robot, v, w, text, points, padding):
        """The law's command steered clear of what is beside the robot (module docstring)."""
        local = pose2d.transform_points(pose2d.inverse(robot), points[:, :2])
        d = steer_clear(local, v, w, self.monitor, self.controller.limits.max_ang_speed, self.params.steer_limit,
                        padding)
        if (d.w == w and d.state != TURN) or d.state not in (CLEAR, SLOW, TURN):
            return v, w, text  # not steered: the monitor slows or stops it as it is
        self.steered += 1
        self.controller.v, self.controller.w = d.v, d.w  # the law's acceleration limits go on from what was sent
        return d.v, d.w, (f"{text}; steered clear of ({d.nearest[0]:.2f}, {d.nearest[1]:.2f}) beside the robot: "
                          f"{w:+.2f} -> {d.w:+.2f} rad/s")

    def result(self):
        out = self.last_step
        return FollowMeResult(*out.person) if out is not None else FollowMeResult()

    def diagnose(self, stat):
        if self.last_step is not None:
            stat.add("distance (m)", f"{self.last_step.distance:.2f}")
        stat.add("control cycles steered clear of what is beside the robot", self.steered)


def main():
    run(FollowMeNode, "follow_me_node")
