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

ROS Subscribers:
    tracked_users (user_tracker_ni/TrackedUsers): people with persistent ids and positions (the
        launch files remap it to filtered_tracked_users).

ROS Publishers:
    cmd_vel (geometry_msgs/Twist): while a goal runs (the launch files remap it to
        cmd_vel_mux/input/follow_me); one zero command when it ends.
    ~state (std_msgs/String): idle, or what the robot does (following, searching).
    /diagnostics: the goal, the person, the tracker's input.
"""

import math
import threading

import rospy
import tf2_ros
from geometry_msgs.msg import Twist
from std_msgs.msg import String

from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.behaviour import Behaviour, aborted
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from florence_common_ros.people import TrackedPeople
from florence_common_ros.reconfigure import Reconfigure
from follow_me.cfg import FollowMeConfig
from follow_me.law import GAINS, Follower, Limits
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
)


class FollowMeNode(Behaviour):
    def __init__(self):
        p = self.params = read_params(PARAMS)
        super().__init__("follow_me", FollowMeAction, p.rate)
        self.lock = threading.Lock()
        self.gains = read_params(GAINS)
        self.person = self.follower = None
        self.frame = None  # the tracker's frame the goal runs in
        self.snap_seen = -math.inf  # [s] arrival of the last tracker message taken
        self.commanding = False
        self.last_step = None
        self.last_end = "no goal yet"
        self.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.state_pub = rospy.Publisher("~state", String, queue_size=1, latch=True)
        self.state_pub.publish(String("idle"))
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.people = TrackedPeople("tracked_users", TrackedUsers, self.tf_buffer, LOG)
        self.diag = Diagnostics("follow_me")
        self.diag.add("FollowMe", self._diagnose)
        self.reconfigure = Reconfigure(FollowMeConfig, GAINS, self._on_gains, LOG)
        self.start()

    def _on_gains(self, gains):
        with self.lock:
            self.gains = gains
            if self.follower is not None:
                self.follower.gains = gains

    # --- the goal ----------------------------------------------------------------------------------
    def limits(self, goal):
        """(Limits, None) after defaults, or (None, why the goal is refused)."""
        p = self.params
        fields = {"x": goal.x, "y": goal.y, "max_lin_speed": goal.max_lin_speed,
                  "max_ang_speed": goal.max_ang_speed, "desired_follow_distance": goal.desired_follow_distance}
        bad = [f"{k} = {v}" for k, v in fields.items() if not math.isfinite(v)]
        bad += [f"{k} = {v} (must be >= 0)" for k, v in list(fields.items())[2:] if v < 0]
        if bad:
            return None, "bad goal: " + ", ".join(bad)
        if math.hypot(goal.x, goal.y) < p.robot_radius:
            return None, (f"bad goal: (x, y) = ({goal.x:.2f}, {goal.y:.2f}) is the robot's own position, not a "
                          "person's")
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
        person, snap, _, why = self.people.attend((goal.x, goal.y), p.base_frame, p.acquire_radius,
                                                  p.tracker_timeout, p.acquire_wait,
                                                  reacquire_radius=p.reacquire_radius)
        if person is None:
            return why
        with self.lock:
            self.frame, self.person, self.snap_seen = snap.frame, person, snap.received
            self.follower = Follower(self.gains, limits, p.rate, p.lost_grace, p.lost_timeout)
            self.commanding = True
        rospy.loginfo(LOG + "following person %d at (%.2f, %.2f) in %s; %.2f m/s, %.2f rad/s, %.2f m", person.pid,
                      person.xy[0], person.xy[1], snap.frame, limits.max_lin_speed, limits.max_ang_speed,
                      limits.desired_distance)
        return None

    def step(self, goal):
        p = self.params
        snap = self.people.latest()
        with self.lock:
            person, follower = self.person, self.follower
            if snap is not None and snap.received > self.snap_seen and snap.frame == self.frame:
                self.snap_seen = snap.received
                person.update(snap.ids, snap.xy, snap.velocities, snap.stamp)
        robot, why = self.people.robot_pose(self.frame, p.base_frame)
        if robot is None:
            self._publish(0.0, 0.0)
            rospy.logwarn_throttle(5.0, LOG + "stopped: %s", why)
            return None
        # the tracker's stamp and the robot's clock are one ROS time
        out = follower.step(rospy.get_time(), robot, person)
        if follower.lost:
            return aborted(f"person lost: {person.pid} unseen for {person.unseen_for(rospy.get_time()):.1f} s "
                           f"(searched where they were last seen)", self.result())
        self._publish(out.v, out.w)
        self.server.publish_feedback(FollowMeFeedback(*out.person))
        self.last_step = out
        self.state_pub.publish(String(out.text))
        return None

    def _publish(self, v, w):
        msg = Twist()
        msg.linear.x, msg.angular.z = v, w
        self.cmd.publish(msg)

    def result(self):
        out = self.last_step
        return FollowMeResult(*out.person) if out is not None else FollowMeResult()

    def halt(self):
        with self.lock:
            was, self.commanding = self.commanding, False
            if self.follower is not None:
                self.follower.stop()
        if was:
            self._publish(0.0, 0.0)
            self.state_pub.publish(String("idle"))

    # --- diagnostics -------------------------------------------------------------------------------
    def _diagnose(self, stat):
        with self.lock:
            person, out, active = self.person, self.last_step, self.commanding
        snap = self.people.latest()
        age = rospy.get_time() - snap.received if snap is not None else math.inf
        level = OK if age <= self.params.tracker_timeout else WARN
        stat.summary(level, out.text if active and out is not None else "idle")
        stat.add("tracked_users", f"{age:.2f} s ago, {self.people.received} received, {self.people.skipped} skipped"
                 if snap is not None else self.people.problem)
        if person is not None:
            stat.add("person", f"{person.pid} (ids {sorted(person.own_ids)})")
        if out is not None:
            stat.add("distance (m)", f"{out.distance:.2f}")
            stat.add("command (m/s, rad/s)", f"{out.v:.2f}, {out.w:.2f}")
        stat.add("gains", ", ".join(f"{k} {v}" for k, v in self.gains.items()))
        return stat


def main():
    run(FollowMeNode, "follow_me_node")
