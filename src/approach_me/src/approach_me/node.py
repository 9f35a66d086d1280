"""approach_me_node: the ApproachMe enabler (seed 4.3, Table 16), an actionlib server on
florence_common_ros.behaviour.Behaviour. Its geometry is approach_me.geometry's (the README has a
figure); phase 1 drives to the position, phase 2 turns to the heading (approach_me.control).

ROS Parameters: PARAMS below, and the gains of approach_me.control.GAINS (~k_linear ..., also served
by dynamic_reconfigure: cfg/ApproachMe.cfg); both tables rendered in the README. ~sources: the
obstacle sensors of collision_monitor (config/sources.yaml), which say whether the pose asked for
is free.

Action server approach_me (approach_me/ApproachMe.action): (x, y) in ~base_frame picks the tracked
person nearest to it (none within ~acquire_radius: ABORTED at once); zero desired_distance,
max_lin_speed, max_ang_speed take ~default_*; feedback (x, y) of the person in ~base_frame every
control cycle; result (x, y) when it ends. SUCCEEDED within ~xy_tolerance and ~yaw_tolerance;
ABORTED with the reason when the person is lost (~lost_timeout), moves away (~max_person_shift),
the pose is inside an obstacle, or the robot makes no progress (~stuck_timeout: the collision
monitor stopped it). Cancel or a new goal: a zero command at once, PREEMPTED.

ROS Subscribers:
    tracked_users (user_tracker_ni/TrackedUsers): people with persistent ids and positions.
    scan (sensor_msgs/LaserScan): the Hokuyo; close up, a leg pair where the person is confirms them
        (user_tracker_ni.laser_legs, ~closeup_range).
    <topic of each source> (sensor_msgs/LaserScan, or a depth image with its camera_info): obstacles
        (/scan; /camera/depth/image, of which 2 frames a second are taken), only while a goal runs.

ROS Publishers:
    cmd_vel (geometry_msgs/Twist): while a goal runs (the launch files remap it to
        cmd_vel_mux/input/approach_me); one zero command when it ends.
    ~state (std_msgs/String): idle, or the phase and what is left.
    ~goal_pose (geometry_msgs/PoseStamped): the pose the robot aims at (rviz).
    /diagnostics: the goal, the person, the tracker's input.
"""

import math

import numpy as np
import rospy
from collision_monitor.obstacles import parse_sources
from collision_monitor.sources import ScanSources
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import LaserScan

from approach_me.cfg import ApproachMeConfig
from approach_me.control import DONE, GAINS, Approacher, Request
from approach_me.estimate import StandingPlace
from approach_me.msg import ApproachMeAction, ApproachMeFeedback, ApproachMeResult
from florence_common import pose as pose2d
from florence_common.params import FRAME, Param, ParamTable
from florence_common.people import nearest
from florence_common_ros.behaviour import aborted, succeeded
from florence_common_ros.convert import pose_stamped
from florence_common_ros.node import read_params, run
from florence_common_ros.people import PersonBehaviour
from florence_common_ros.transforms import lookup_matrix
from user_tracker_ni import laser_legs
from user_tracker_ni.msg import TrackedUsers

LOG = "approach_me: "
PARAMS = ParamTable(
    Param("rate", float, 10.0, "control cycles per second (feedback with each)", unit="Hz", gt=0, le=50),
    Param("base_frame", FRAME, "base_link", "the robot frame of the goal, the feedback and the result"),
    Param("sources", list, None, "the obstacle sensors, as collision_monitor's ~sources (config/sources.yaml); "
          "unset: the pose is not checked", optional=True),
    Param("acquire_radius", float, 0.6, "the goal's (x, y) picks the tracked person within this of it", unit="m",
          gt=0),
    Param("tracker_timeout", float, 1.0, "a goal needs a tracked_users message this recent", unit="s", gt=0),
    Param("acquire_wait", float, 0.5, "how long a goal waits for the tracker's next messages when the latest has "
          "nobody near (x, y) (a track that flickered)", unit="s", ge=0, le=5),
    Param("default_distance", float, 0.6, "desired_distance of a goal that leaves it 0 (personal space: "
          "0.45-1.2 m)", unit="m", gt=0),
    Param("default_max_lin_speed", float, 0.3, "max_lin_speed of a goal that leaves it 0", unit="m/s", gt=0, le=0.5),
    Param("default_max_ang_speed", float, 1.0, "max_ang_speed of a goal that leaves it 0", unit="rad/s", gt=0, le=3),
    Param("robot_radius", float, 0.18, "the robot's radius (with ~person_radius: the least desired_distance; the "
          "clearance the pose needs from obstacles)", unit="m", gt=0),
    Param("person_radius", float, 0.25, "a person's radius", unit="m", gt=0),
    Param("xy_tolerance", float, 0.05, "the goal position is reached within this", unit="m", gt=0),
    Param("yaw_tolerance", float, 0.05, "the final heading is reached within this", unit="rad", gt=0),
    Param("lost_timeout", float, 3.0, "a person unseen this long ends the goal ABORTED", unit="s", gt=0),
    Param("max_person_shift", float, 1.0, "a person who moves this far from where they were at goal time ends the "
          "goal ABORTED", unit="m", gt=0),
    Param("stuck_timeout", float, 5.0, "no progress of 0.05 m toward the position for this long ends the goal "
          "ABORTED (blocked)", unit="s", gt=0),
    Param("time_limit", float, 60.0, "a goal not reached in this long ends ABORTED", unit="s", gt=0),
    Param("reacquire_radius", float, 0.5, "a new track this near where the person was expected is taken for them",
          unit="m", gt=0),
    Param("closeup_range", float, 1.5, "nearer than this, a pair of legs the laser sees (user_tracker_ni's leg "
          "detector on scan) within ~closeup_radius of the person confirms them and their place (0: off)", unit="m",
          ge=0),
    Param("closeup_radius", float, 0.25, "how near the person's place a leg pair must be to confirm them", unit="m",
          gt=0),
    Param("far_range", float, 1.0, "a standing person's place is the mean of the sightings from at least this far "
          "(nearer, the Kinect cuts their torso and one leg may hide the other; approach_me.estimate)", unit="m",
          ge=0),
    Param("still_radius", float, 0.15, "nearer sightings this close to the place leave it; farther ones for 0.5 s "
          "mean the person moved and start it over", unit="m", gt=0),
)


class ApproachMeNode(PersonBehaviour):
    def __init__(self):
        p = read_params(PARAMS)
        specs = parse_sources(p.sources) if p.sources is not None else []
        super().__init__("approach_me", ApproachMeAction, p, GAINS, ApproachMeConfig, TrackedUsers, "ApproachMe",
                         LOG)
        self.last_step = None  # (Step, robot pose, person xy) of the last control cycle
        self.goal_pub = rospy.Publisher("~goal_pose", PoseStamped, queue_size=1, latch=True)
        # a depth source at 2 frames a second: its 3-D memory costs the monitor 4-6 ms a frame, and here
        # the points only check the pose a goal asks for; subscribed during goals only (PersonBehaviour)
        self.obstacles = ScanSources(specs, "odom", self.tf_buffer, log_prefix=LOG, depth_period=0.5,
                                     subscribe=False) if specs else None
        self.leg_params = laser_legs.LegParams()
        self.closeup = None  # (ROS time [s], leg pairs [P, 2] in the tracker's frame) of the last scan
        self.closeup_confirmed = 0
        if p.closeup_range > 0:
            self.scan_sub = rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=1)
        self.start()

    def _on_scan(self, msg):
        """Leg pairs in the laser's scan, in the tracker's frame (close-up confirmation of the person)."""
        frame = self.frame
        if frame is None or not self.commanding or not msg.header.frame_id:
            return  # (no goal: nothing to confirm)
        m, why = lookup_matrix(self.tf_buffer, frame, msg.header.frame_id.lstrip("/"), msg.header.stamp, 0.3)
        if m is None:
            rospy.logdebug(LOG + "scan skipped: %s", why)
            return
        _, people = laser_legs.detect(msg.ranges, msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max, m,
                                      self.leg_params)
        self.closeup = (rospy.get_time(), people)

    def _confirm_closeup(self, person, robot, now):
        """The tracker may lose a standing person close up (the Kinect sees no upper body nearer than
        about 1.1 m, and its laser track may hold one leg): a leg pair the laser sees where they are
        confirms them and their place."""
        p = self.params
        if self.closeup is None or math.dist(robot[:2], person.xy) > p.closeup_range:
            return
        t, pairs = self.closeup
        if now - t > 0.5 or not len(pairs):
            return
        k, _ = nearest(pairs, person.xy, p.closeup_radius)
        if k is not None:
            person.confirm(pairs[k], t)
            self.closeup_confirmed += 1

    # --- the goal ----------------------------------------------------------------------------------
    def request(self, goal):
        """(Request, None) after defaults, or (None, why the goal is refused)."""
        p = self.params
        why = self.check_goal(goal, ("x", "y", "desired_distance", "desired_p2r_orientation",
                                     "desired_r2p_orientation", "max_lin_speed", "max_ang_speed"),
                              ("desired_distance", "max_lin_speed", "max_ang_speed"))
        if why:
            return None, why
        req = Request(goal.desired_distance or p.default_distance, goal.desired_p2r_orientation,
                      goal.desired_r2p_orientation, min(goal.max_lin_speed or p.default_max_lin_speed, 0.5),
                      goal.max_ang_speed or p.default_max_ang_speed)
        nearest_ok = p.robot_radius + p.person_radius
        if req.distance < nearest_ok:
            return None, (f"bad goal: desired_distance {req.distance:.2f} m is below the robot's radius plus a "
                          f"person's ({nearest_ok:.2f} m)")
        return req, None

    def begin(self, goal):
        p = self.params
        req, why = self.request(goal)
        if why:
            return why

        def make(person, robot, frame):
            approacher = Approacher(self.gains, req, person.xy, robot[:2], p.rate, p.xy_tolerance, p.yaw_tolerance)
            return self._blocked(frame, approacher.goal(person.xy)) or approacher

        why = self.attend(goal, make, max_extrapolation=0.3)
        if why:
            return why
        with self.lock:
            self.person0 = self.person.xy
            self.started = rospy.get_time()
            self.progress = (math.inf, self.started)  # (least distance left [m], when)
            self.last_step = None
            self.place, self.place_seen = StandingPlace(p.far_range, p.still_radius), -math.inf
        rospy.loginfo(LOG + "approaching person %d at (%.2f, %.2f) in %s: %.2f m, p2r %.2f rad, r2p %.2f rad",
                      self.person.pid, *self.person.xy, self.frame, req.distance, req.p2r, req.r2p)
        return None

    def _blocked(self, frame, goal_xy):
        """Why the goal position is not free (an obstacle point within the robot's radius), or None."""
        if self.obstacles is None:
            return None
        points, _ = self.obstacles.points()
        if not len(points):
            return None
        if frame != "odom":
            m, _ = self.people.robot_pose(frame, "odom")  # odom in the tracker's frame
            if m is None:
                return None
            points = pose2d.transform_points(m, points[:, :2])
        gap = np.hypot(points[:, 0] - goal_xy[0], points[:, 1] - goal_xy[1])
        k = int(np.argmin(gap))
        if gap[k] < self.params.robot_radius:
            return (f"the pose cannot be reached: its position ({goal_xy[0]:.2f}, {goal_xy[1]:.2f}) in {frame} is "
                    f"inside an obstacle ({gap[k]:.2f} m from a return of the laser or the Kinect)")
        return None

    def step(self, goal):
        p = self.params
        now = rospy.get_time()
        person = self.take_reports()
        robot = self.robot_pose()
        if robot is None:
            return None
        self._confirm_closeup(person, robot, now)
        if person.seen_at > self.place_seen or self.place.xy is None:
            self.place_seen = person.seen_at
            self.place.update(person.xy, robot[:2], person.seen_at)
        xy = self.place.xy
        ending = self._ending(person, now)
        if ending is not None:
            return ending
        out = self.controller.step(robot, xy)
        self.last_step = (out, robot, xy)
        self.server.publish_feedback(ApproachMeFeedback(*self.local(robot, xy)))
        if out.phase == DONE:
            self.drive(0.0, 0.0, out.text)
            return succeeded(f"reached: {out.position_error:.3f} m from the position, {abs(out.heading_error):.3f} "
                             "rad from the heading", self.result())
        left, since = self.progress
        if out.position_error < left - 0.05 or out.phase != "drive":
            self.progress = (out.position_error, now)
        elif now - since > p.stuck_timeout:
            return aborted(f"the pose cannot be reached: no progress for {p.stuck_timeout:.0f} s, "
                           f"{out.position_error:.2f} m from it (blocked by an obstacle?)", self.result())
        self.drive(out.v, out.w, out.text)
        self.goal_pub.publish(pose_stamped(*out.goal, self.frame, rospy.Time.now()))
        return None

    def _ending(self, person, now):
        """ABORTED when the person is lost or moved away, or time is up; else None."""
        p = self.params
        if person.unseen_for(now) > p.lost_timeout:
            return aborted(f"person lost: {person.pid} unseen for {person.unseen_for(now):.1f} s", self.result())
        shift = math.dist(person.xy, self.person0)
        if shift > p.max_person_shift:
            return aborted(f"the person moved away: {shift:.2f} m from where they were (more than "
                           f"{p.max_person_shift:.2f} m)", self.result())
        if now - self.started > p.time_limit:
            return aborted(f"the pose was not reached in {p.time_limit:.0f} s", self.result())
        return None

    def result(self):
        if self.last_step is None:
            return ApproachMeResult()
        _, robot, xy = self.last_step
        return ApproachMeResult(*self.local(robot, xy))

    def diagnose(self, stat):
        if self.last_step is not None:
            out = self.last_step[0]
            stat.add("phase", out.phase)
            stat.add("position error (m)", f"{out.position_error:.3f}")
            stat.add("heading error (rad)", f"{out.heading_error:.3f}")
        stat.add("close-up confirmations by the laser's legs", self.closeup_confirmed)
        if self.obstacles is not None:
            stat.add("obstacle sources", ", ".join(f"{n} {a:.1f} s ago"
                                                   for n, a in self.obstacles.ages(rospy.get_time()).items()))


def main():
    run(ApproachMeNode, "approach_me_node")
