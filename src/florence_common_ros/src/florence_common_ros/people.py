"""The people a user tracker reports, for the behaviours that attend to one of them (follow_me,
approach_me): the latest user_tracker_ni/TrackedUsers as arrays, and the robot's pose in the
tracker's fixed frame.

    people = TrackedPeople("tracked_users", TrackedUsers, tf_buffer, log_prefix="follow_me: ")
    snap = people.latest()            # Snapshot or None; people.problem says why not
    robot, why = people.robot_pose(snap.frame, "base_link")   # (x, y, yaw) in the tracker's frame

The message class is passed in (this package does not depend on the people packages). A message
that cannot be read (no positions, lists of other lengths, no frame) is skipped with a throttled
warning; :attr:`TrackedPeople.problem` keeps the reason for the behaviour's abort text.

:class:`PersonBehaviour` is the part follow_me and approach_me share on the Behaviour base.
"""

import math
import threading
import time
from dataclasses import dataclass

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Twist
from std_msgs.msg import String

from florence_common import pose as pose2d
from florence_common.people import acquire
from florence_common_ros.behaviour import Behaviour
from florence_common_ros.convert import tracked_users
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import read_params
from florence_common_ros.reconfigure import Reconfigure
from florence_common_ros.transforms import lookup_matrix

SOURCES_WAIT = 1.0  # [s] of wall time a goal waits for the first scan or image of each obstacle source


@dataclass(frozen=True)
class Snapshot:
    ids: np.ndarray  # [N] persistent ids
    xy: np.ndarray  # [N, 2] [m] in ``frame``
    velocities: np.ndarray  # [N, 2] [m/s]
    frame: str
    stamp: float  # [s] of the tracker's newest reading
    received: float  # [s] ROS time it arrived


class TrackedPeople:
    def __init__(self, topic, msg_class, tf_buffer, log_prefix=""):
        self.tf_buffer = tf_buffer
        self.log_prefix = log_prefix
        self.lock = threading.Lock()
        self._latest = None
        self.received = 0
        self.skipped = 0
        self.problem = f"no message on {rospy.resolve_name(topic)} yet (is user_tracker_ni running?)"
        self.sub = rospy.Subscriber(topic, msg_class, self._on_users, queue_size=1)

    def _on_users(self, msg):
        frame = msg.frame_id.lstrip("/") if hasattr(msg, "frame_id") else ""
        try:
            if not frame and len(msg.user_ids):
                raise ValueError("the message has no frame_id")
            ids, xy, vxy = tracked_users(msg)
        except ValueError as exc:
            with self.lock:
                self.skipped += 1
                self.problem = f"unreadable {self.sub.name} message: {exc}"
            rospy.logwarn_throttle(5.0, self.log_prefix + self.problem)
            return
        snap = Snapshot(ids, xy, vxy, frame, msg.stamp.to_sec(), rospy.get_time())
        with self.lock:
            self._latest = snap
            self.received += 1

    def latest(self, max_age=None):
        """The newest Snapshot, or None (none yet, or older than ``max_age`` [s] of ROS time: then
        :attr:`problem` says so)."""
        with self.lock:
            snap = self._latest
        if snap is None:
            return None
        age = rospy.get_time() - snap.received
        if max_age is not None and age > max_age:
            self.problem = f"no message on {self.sub.name} for {age:.1f} s (is user_tracker_ni running?)"
            return None
        return snap

    def attend(self, goal_xy, base_frame, radius, max_age, wait=0.5, **kwargs):
        """The tracked person nearest to ``goal_xy`` (x, y) in ``base_frame`` within ``radius`` [m]:
        (florence_common.people.AttendedPerson, Snapshot, robot pose in the tracker's frame, None), or
        (None, None, None, why not). The tracker's next messages are waited for up to ``wait`` [s of
        wall time] when the latest has nobody there (a track that flickered). ``kwargs`` go to the
        AttendedPerson."""
        deadline = time.monotonic() + wait
        while True:
            snap = self.latest(max_age=max_age)
            if snap is None:
                why = self.problem
            else:
                robot, why = self.robot_pose(snap.frame or "odom", base_frame)
                if robot is not None:
                    point = pose2d.transform_points(robot, [goal_xy])[0]
                    person, why = acquire(snap.ids, snap.xy, snap.velocities, snap.stamp, point, radius, **kwargs)
                    if person is not None:
                        return person, snap, robot, None
                    why = f"{why} (goal ({goal_xy[0]:.2f}, {goal_xy[1]:.2f}) in {base_frame})"
            if time.monotonic() >= deadline or rospy.is_shutdown():
                return None, None, None, why
            time.sleep(0.05)

    def robot_pose(self, frame, base_frame):
        """((x, y, yaw) of ``base_frame`` in ``frame``, latest), or (None, why)."""
        m, why = lookup_matrix(self.tf_buffer, frame, base_frame, rospy.Time(0))
        if m is None:
            return None, why
        return pose2d.from_matrix(m), None

    def unregister(self):
        self.sub.unregister()


class PersonBehaviour(Behaviour):
    """The part every behaviour that drives the robot about a tracked person shares (follow_me,
    approach_me), on the Behaviour base: the goal's (x, y) checks, the person picked and kept, the
    robot's pose, the commands on ``cmd_vel`` (one zero when a goal ends, nothing between goals),
    ``~state``, ``/diagnostics`` and the gains served by dynamic_reconfigure.

    ``params`` needs rate, base_frame, robot_radius, acquire_radius, tracker_timeout, acquire_wait,
    reacquire_radius. The subclass makes its controller in ``begin`` (:meth:`attend`), drives in
    ``step`` (:meth:`take_reports`, :meth:`robot_pose`, :meth:`drive`), may add to the diagnostics
    (:meth:`diagnose`), and calls ``start()`` last in its constructor. The controller has ``gains``
    (replaced on a reconfiguration) and ``stop()``."""

    def __init__(self, name, action_class, params, gains_table, config_type, users_class, title, log_prefix):
        super().__init__(name, action_class, params.rate)
        self.params = params
        self.log = log_prefix
        self.lock = threading.Lock()
        self.gains = read_params(gains_table)
        self.person = self.controller = None
        self.frame = None  # the tracker's frame the goal runs in
        self.snap_seen = -math.inf  # [s] arrival of the last tracker message taken
        self.commanding = False
        self.status = None  # (text, v, w) of the last control cycle
        # the subclass's obstacle sources (collision_monitor.sources.ScanSources made with subscribe=False),
        # or None: subscribed from the start of a goal (attend) to its end (halt)
        self.obstacles = None
        self.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.state_pub = rospy.Publisher("~state", String, queue_size=1, latch=True)
        self.state_pub.publish(String("idle"))
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.people = TrackedPeople("tracked_users", users_class, self.tf_buffer, log_prefix)
        self.diag = Diagnostics(name)
        self.diag.add(title, self._diagnose)
        self.reconfigure = Reconfigure(config_type, gains_table, self._on_gains, log_prefix)

    def _on_gains(self, gains):
        with self.lock:
            self.gains = gains
            if self.controller is not None:
                self.controller.gains = gains

    # --- the goal ----------------------------------------------------------------------------------
    def check_goal(self, goal, fields, nonnegative):
        """Why the goal is refused, or None: any of ``fields`` (names) not finite, any of
        ``nonnegative`` below 0, (x, y) at the robot's own position."""
        values = {k: getattr(goal, k) for k in fields}
        bad = [f"{k} = {v}" for k, v in values.items() if not math.isfinite(v)]
        bad += [f"{k} = {values[k]} (must be >= 0)" for k in nonnegative if values[k] < 0]
        if bad:
            return "bad goal: " + ", ".join(bad)
        if math.hypot(goal.x, goal.y) < self.params.robot_radius:
            return f"bad goal: (x, y) = ({goal.x:.2f}, {goal.y:.2f}) is the robot's own position, not a person's"
        return None

    def attend(self, goal, make_controller, **person_args):
        """Pick the tracked person nearest the goal's (x, y) and make the controller
        (``make_controller(person, robot_pose, frame)``, in the tracker's frame; or a reason text to
        refuse); None, or why not. The obstacle sources are subscribed first, and their first scan or
        image waited for up to SOURCES_WAIT (the controller may check the goal against them)."""
        p = self.params
        if self.obstacles is not None:
            self.obstacles.resume()
            missing = self.obstacles.wait_all(SOURCES_WAIT)
            if missing:
                rospy.logwarn(self.log + "nothing from %s within %.1f s of the goal: going on without",
                              ", ".join(missing), SOURCES_WAIT)
        person, snap, robot, why = self.people.attend((goal.x, goal.y), p.base_frame, p.acquire_radius,
                                                      p.tracker_timeout, p.acquire_wait,
                                                      reacquire_radius=p.reacquire_radius, **person_args)
        if person is None:
            return why
        controller = make_controller(person, robot, snap.frame)
        if isinstance(controller, str):
            return controller
        with self.lock:
            self.frame, self.person, self.snap_seen = snap.frame, person, snap.received
            self.controller, self.commanding = controller, True
        return None

    # --- a control cycle -----------------------------------------------------------------------------
    def take_reports(self):
        """The person, updated with the tracker's newest message if it has not been taken yet."""
        snap = self.people.latest()
        with self.lock:
            if snap is not None and snap.received > self.snap_seen and snap.frame == self.frame:
                self.snap_seen = snap.received
                self.person.update(snap.ids, snap.xy, snap.velocities, snap.stamp)
            return self.person

    def robot_pose(self):
        """The robot's pose in the tracker's frame, or None (then it stands, with a warning)."""
        robot, why = self.people.robot_pose(self.frame, self.params.base_frame)
        if robot is None:
            self.publish(0.0, 0.0)
            rospy.logwarn_throttle(5.0, self.log + "stopped: %s", why)
        return robot

    def local(self, robot, xy):
        """(x, y) of ``xy`` (tracker's frame) in the robot frame."""
        x, y = pose2d.transform_points(pose2d.inverse(robot), [xy])[0]
        return float(x), float(y)

    def publish(self, v, w):
        msg = Twist()
        msg.linear.x, msg.angular.z = v, w
        self.cmd.publish(msg)

    def drive(self, v, w, text):
        """Send a command and say what the robot does; nothing once the goal was halted (a cancel
        comes on the action server's thread, maybe while this cycle computes its command)."""
        with self.lock:
            if not self.commanding:
                return
            self.publish(v, w)
            self.status = (text, v, w)
            self.state_pub.publish(String(text))

    def halt(self):
        """Stop the robot: one zero command, under the lock, so that no cycle's command follows it."""
        with self.lock:
            was, self.commanding = self.commanding, False
            if self.controller is not None:
                self.controller.stop()
            if was:
                self.publish(0.0, 0.0)
                self.state_pub.publish(String("idle"))
        if self.obstacles is not None:
            self.obstacles.pause()

    # --- diagnostics -------------------------------------------------------------------------------
    def diagnose(self, stat):
        """The subclass's own lines."""

    def _diagnose(self, stat):
        with self.lock:
            person, status, active = self.person, self.status, self.commanding
        snap = self.people.latest()
        age = rospy.get_time() - snap.received if snap is not None else math.inf
        stat.summary(OK if age <= self.params.tracker_timeout else WARN,
                     status[0] if active and status is not None else "idle")
        stat.add("tracked_users", f"{age:.2f} s ago, {self.people.received} received, {self.people.skipped} skipped"
                 if snap is not None else self.people.problem)
        if person is not None:
            stat.add("person", f"{person.pid} (ids {sorted(person.own_ids)})")
        if status is not None:
            stat.add("command (m/s, rad/s)", f"{status[1]:.2f}, {status[2]:.2f}")
        self.diagnose(stat)
        stat.add("gains", ", ".join(f"{k} {v}" for k, v in self.gains.items()))
        return stat
