"""Send move_base goals in florence_sim and record what the robot did (tests, bench and demo).

Runs inside a rospy node that the caller initialised, against a master where
``turtlebot_2dnav_control.launch sim:=true`` runs. Times are simulated time taken from the
simulator's ground truth stamps, so the judgement does not depend on this process's clock.
"""

import bisect
import math
import threading
import time

import numpy as np
import rospy
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import Odometry
from nav_msgs.srv import GetPlan
from std_msgs.msg import UInt32

from florence_common_ros import convert
from florence_common_ros.actions import SimpleActionClient
from florence_eval import sim_now

STATE_NAMES = {v: k for k, v in vars(GoalStatus).items() if isinstance(v, int) and k.isupper()}


def make_goal(x, y, yaw, frame="map"):
    """A MoveBaseGoal at (x [m], y [m]) heading ``yaw`` [rad] in ``frame``."""
    return MoveBaseGoal(target_pose=convert.pose_stamped(x, y, yaw, frame))


class TruthRecorder:
    """A recorder of florence_sim's ground truth (the robot's pose and speeds, and with
    ``record_people`` the people's positions) and collisions."""

    def __init__(self, record_people=False):
        self.lock = threading.Lock()
        self.truth = []  # (t [s], x [m], y [m], yaw [rad], v [m/s], w [rad/s])
        self.collisions = 0
        self.collision_poses = []  # ground truth (t, x, y, yaw, v, w) when the bumper count went up
        self.people = []  # (t [s], {person id: (x [m], y [m])}) from people_ground_truth
        self.subs = [
            rospy.Subscriber("base_pose_ground_truth", Odometry, self._on_truth, queue_size=100),
            rospy.Subscriber("collisions", UInt32, self._on_collisions, queue_size=10),
        ]
        if record_people:
            from florence_sim.msg import People

            self.subs.append(rospy.Subscriber("people_ground_truth", People, self._on_people, queue_size=20))

    def _on_truth(self, msg):
        p, t = msg.pose.pose, msg.twist.twist
        with self.lock:
            self.truth.append((msg.header.stamp.to_sec(), p.position.x, p.position.y, convert.yaw_of(p.orientation),
                               math.hypot(t.linear.x, t.linear.y), t.angular.z))

    def _on_people(self, msg):
        where = {p.id: (p.pose.position.x, p.pose.position.y) for p in msg.people}
        with self.lock:
            self.people.append((msg.header.stamp.to_sec(), where))

    def _on_collisions(self, msg):
        with self.lock:
            if msg.data > self.collisions and self.truth:
                self.collision_poses.append(tuple(round(v, 3) for v in self.truth[-1]))
            self.collisions = msg.data

    def close(self):
        for sub in self.subs:
            sub.unregister()

    # --- state ---------------------------------------------------------------------------------
    def latest(self):
        with self.lock:
            return self.truth[-1] if self.truth else None

    def sim_now(self):
        last = self.latest()
        return last[0] if last else 0.0

    def catch_up(self, timeout=60.0):
        """Wait until the recorded ground truth reaches the simulator's present (sim_now.py)."""
        return sim_now.catch_up(self.sim_now, timeout)

    def track(self, since=0.0):
        """Ground-truth rows (t, x, y, yaw, v, w) stamped at or after ``since`` [s] (the stamps
        grow: the rows are found by bisection, not by a scan of the whole history)."""
        with self.lock:
            first = bisect.bisect_left(self.truth, since, key=lambda row: row[0])
            return np.array(self.truth[first:]).reshape(-1, 6)

    def people_track(self, since=0.0):
        """Every person's ground truth stamped at or after ``since`` [s] (one second earlier too, so
        that the first rows of a leg can be interpolated): {person id: (N, 3) array of (t [s], x [m],
        y [m])}."""
        with self.lock:
            first = bisect.bisect_left(self.people, since - 1.0, key=lambda row: row[0])
            rows = self.people[first:]
        out = {}
        for t, where in rows:
            for pid, (x, y) in where.items():
                out.setdefault(pid, []).append((t, x, y))
        return {pid: np.array(v) for pid, v in out.items()}


class NavSession(TruthRecorder):
    """An actionlib client of move_base plus a recorder of ground truth (the people's too) and collisions."""

    def __init__(self, action="move_base", record_people=True):
        super().__init__(record_people)
        self.client = SimpleActionClient(action, MoveBaseAction)
        self._make_plan = None  # ~make_plan's proxy, made on first use

    def is_active(self):
        """Whether move_base has accepted the current goal and works on it (ACTIVE)."""
        return self.client.get_state() == GoalStatus.ACTIVE

    def wait_still(self, sim_time=0.5, timeout=60.0, v=0.01, w=0.01):
        """Wait (wall ``timeout``) until the ground truth speeds stayed within ``v`` [m/s] and ``w``
        [rad/s] for ``sim_time`` simulated seconds; False if the robot did not come to rest."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            track = self.track(since=self.sim_now() - sim_time)
            if (len(track) > 1 and track[-1, 0] - track[0, 0] >= 0.9 * sim_time
                    and np.all(np.abs(track[:, 4]) <= v) and np.all(np.abs(track[:, 5]) <= w)):
                return True
            time.sleep(0.02)
        return False

    def wait_ready(self, timeout=120.0):
        """Wait (wall time) for the action server and ground truth; False if they did not come."""
        deadline = time.monotonic() + timeout
        if not self.client.wait_for_server(rospy.Duration(timeout)):
            return False
        while time.monotonic() < deadline:
            if self.latest() is not None:
                return True
            time.sleep(0.05)
        return False

    # --- plans -------------------------------------------------------------------------------------
    def plan(self, start, goal, frame="map", service="/move_base/make_plan", timeout=60.0):
        """The (N, 2) path [m] move_base's ~make_plan gives from ``start`` to ``goal`` (x, y, yaw) in
        ``frame`` with tolerance 0, or None when it finds none."""
        if self._make_plan is None:
            rospy.wait_for_service(service, timeout)
            self._make_plan = rospy.ServiceProxy(service, GetPlan)
        plan = self._make_plan(start=convert.pose_stamped(*start, frame), goal=convert.pose_stamped(*goal, frame),
                               tolerance=0.0).plan
        if not plan.poses:
            return None
        return np.array([[p.pose.position.x, p.pose.position.y] for p in plan.poses])

    # --- goals ---------------------------------------------------------------------------------
    def send(self, x, y, yaw, frame="map"):
        self.client.send_goal(make_goal(x, y, yaw, frame))

    def wait_result(self, sim_timeout, wall_timeout=None):
        """Wait until the goal ends (and the recorders reach the simulator's present: catch_up) or
        ``sim_timeout`` simulated seconds pass (and, as a backstop when the simulation stalls,
        ``wall_timeout`` wall seconds). Returns (state name, text)."""
        start_sim = self.sim_now()
        deadline = time.monotonic() + (wall_timeout if wall_timeout is not None else 20.0 * sim_timeout + 60.0)
        while time.monotonic() < deadline:
            state = self.client.get_state()
            if state not in (GoalStatus.PENDING, GoalStatus.ACTIVE):
                self.catch_up()
                return STATE_NAMES.get(state, str(state)), self.client.get_goal_status_text()
            if self.sim_now() - start_sim > sim_timeout:
                return "TIMEOUT", f"no result after {sim_timeout:.0f} s of simulated time"
            time.sleep(0.02)
        return "TIMEOUT", f"no result after {wall_timeout} s of wall time (simulation stalled?)"

    def go(self, x, y, yaw, sim_timeout=120.0, frame="map"):
        """Send a goal and wait for its end; returns (state, text, sim seconds taken, path length [m])."""
        t0 = self.sim_now()
        self.send(x, y, yaw, frame)
        state, text = self.wait_result(sim_timeout)
        if state == "TIMEOUT":
            self.client.cancel_all_goals()
        track = self.track(since=t0)
        length = float(np.sum(np.hypot(np.diff(track[:, 1]), np.diff(track[:, 2])))) if len(track) > 1 else 0.0
        return state, text, self.sim_now() - t0, length
