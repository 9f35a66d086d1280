"""The robot enablers in florence_sim, driven and recorded for their evaluation (the scenario tests and
bench/enablers.py).

Runs inside a rospy node that the caller initialised, against a master where
``florence_eval/launch/enablers_sim.launch`` runs (:func:`launch_stack`): florence_sim, the filters
with the collision monitor, the Kinect's fake laser, map_server, amcl, user_tracker.launch,
follow_me and approach_me. It records, in simulated time (ground truth stamps), what the robot and
the people truly did, the bumper contacts, the tracker's output, what the enablers and the monitor
said and sent; it sends FollowMe and ApproachMe goals as a client would (the person's position in
the robot frame, here taken from the simulator, stands for what detect_users gives), and it drives
teleop on the multiplexer's teleop input.
"""

import itertools
import math
import time

import numpy as np
import rosgraph
import rospy
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist
from std_msgs.msg import String, UInt32

from florence_common import pose as pose2d
from florence_common.processes import roslaunch, wait_for
from florence_common_ros.actions import SimpleActionClient
from florence_eval.people_session import PeopleSession, _registered

TELEOP = "/cmd_vel_mux/input/teleop"
START_TOLERANCE = 0.05  # [m] a follow trial's person sets off once the robot stands this near the distance
IDEAL_DELAYS = (0.0, 0.1, 0.3, 0.6)  # [s] a perfect follower seeing the person this late: its RMS error, reported
DROPPED = "users dropped: "  # user_tracker_ni's /diagnostics keys, by reason
DIAGNOSTICS_WAIT = 1.5  # [s] user_tracker_ni's /diagnostics come every second: a trial's drops are read this later
STATE_NAMES = {v: k for k, v in vars(GoalStatus).items() if isinstance(v, int) and k.isupper()}
NODES = ("/florence_sim", "/collision_monitor", "/velocity_filter_node", "/user_tracker_ni_node", "/follow_me_node",
         "/approach_me_node")


def launch_stack(master, start, real_time_factor=1.0, seed=1, people=None, lost_timeout=10.0, localization=True):
    """Start enablers_sim.launch (``people``: a people file, None: nobody) with the robot at
    ``start`` (x, y, yaw); wait for its nodes; returns the process (the caller stops it)."""
    import tempfile
    from pathlib import Path

    if people is None:
        people = Path(tempfile.mkdtemp(prefix="people-")) / "nobody.yaml"
        people.write_text("people: []\n")
    x, y, yaw = start
    proc = roslaunch(master, "florence_eval", "enablers_sim.launch", f"people:={people}",
                     f"real_time_factor:={real_time_factor}", f"seed:={seed}", f"x:={x}", f"y:={y}", f"yaw:={yaw}",
                     f"lost_timeout:={lost_timeout}", f"localization:={str(localization).lower()}")
    graph = rosgraph.Master("/launch_stack", master_uri=master.uri)
    try:
        for node in NODES:
            wait_for(lambda n=node: _registered(graph, n), 180, what=f"{node} to start")
    except Exception:
        print(f"----- enablers_sim.launch -----\n{proc.output(6000)}")
        proc.stop()
        raise
    return proc


class EnablersSession(PeopleSession):
    """PeopleSession (ground truth, people, the tracker, florence_sim's scene services) driving
    teleop, plus the enablers' action clients and what the enablers and the monitor said."""

    def __init__(self):
        from approach_me.msg import ApproachMeAction
        from follow_me.msg import FollowMeAction

        from collision_monitor.msg import MonitorState

        super().__init__(tracked_topic="/tracked_users", cmd_vel=TELEOP, filtered_topic="/filtered_tracked_users")
        self.collisions = 0
        self.monitor = []  # (t, state, v in, v out, reason, nearest x, y in the robot frame)
        self.states = {"follow_me": [], "approach_me": []}  # (t, text)
        self.commands = {"mux": [], "monitor": [], "filter": []}  # (t [sim s], wall [s], v, w)
        self.feedback = []  # (t, action, x, y) in the robot frame
        self.tracker_drops = {}  # reason -> users user_tracker_ni dropped so far (its /diagnostics)
        self.follow_client = SimpleActionClient("follow_me", FollowMeAction)
        self.approach_client = SimpleActionClient("approach_me", ApproachMeAction)
        self.subs += [
            rospy.Subscriber("/collisions", UInt32, self._on_collisions, queue_size=10),
            rospy.Subscriber("/collision_monitor/state", MonitorState, self._on_monitor, queue_size=50),
            rospy.Subscriber("/follow_me_node/state", String, self._on_state, callback_args="follow_me", queue_size=50),
            rospy.Subscriber("/approach_me_node/state", String, self._on_state, callback_args="approach_me",
                             queue_size=50),
            rospy.Subscriber("/cmd_vel_mux/output", Twist, self._on_command, callback_args="mux", queue_size=100,
                             tcp_nodelay=True),
            rospy.Subscriber("/cmd_vel", Twist, self._on_command, callback_args="monitor", queue_size=100,
                             tcp_nodelay=True),
            rospy.Subscriber("/filtered_cmd_vel", Twist, self._on_command, callback_args="filter", queue_size=100),
            rospy.Subscriber("/diagnostics", DiagnosticArray, self._on_diagnostics, queue_size=20),
        ]

    # --- recording ---------------------------------------------------------------------------------
    def _on_collisions(self, msg):
        with self.lock:
            self.collisions = msg.data

    def _on_monitor(self, msg):
        with self.lock:
            self.monitor.append((self.sim_now(), msg.state, msg.command.linear.x, msg.output.linear.x, msg.reason,
                                 msg.nearest.x, msg.nearest.y))

    def _on_state(self, msg, name):
        with self.lock:
            self.states[name].append((self.sim_now(), msg.data))

    def _on_diagnostics(self, msg):
        for status in msg.status:
            if status.name.startswith("user_tracker") and status.name.endswith(": Tracking"):
                drops = {v.key[len(DROPPED):]: int(v.value) for v in status.values if v.key.startswith(DROPPED)}
                with self.lock:
                    self.tracker_drops = drops

    def drops_since(self, before):
        """{reason: users the tracker dropped} since its counts were ``before`` (self.tracker_drops then)."""
        with self.lock:
            now = dict(self.tracker_drops)
        return {k: n - before.get(k, 0) for k, n in now.items() if n > before.get(k, 0)}

    def _on_command(self, msg, where):
        wall = time.perf_counter()
        with self.lock:
            self.commands[where].append((self.sim_now(), wall, msg.linear.x, msg.angular.z))

    def sim_now(self):
        # the lock is re-entrant for this read: truth rows are appended whole
        return self.truth[-1][0] if self.truth else 0.0

    def wait_ready(self, timeout=180.0):
        wait_for(lambda: self.sim_now() > 1.0, timeout, what="florence_sim's clock")
        for client in (self.follow_client, self.approach_client):
            if not client.wait_for_server(rospy.Duration(timeout)):
                raise RuntimeError(f"no action server {client.action_client.ns}")
        rospy.wait_for_service("/user_tracker_ni_node/Stop", timeout)
        rospy.wait_for_service("/user_tracker_ni_node/Start", timeout)
        time.sleep(1.0)  # a fresh action client's first goal can be lost while connections settle

    def pose(self):
        """The robot's true pose (x, y, yaw) in the map."""
        with self.lock:
            return tuple(self.truth[-1][1:]) if self.truth else None

    def person(self, pid):
        """A person's true (x, y) in the map, or None."""
        with self.lock:
            return self.people[-1][1].get(pid) if self.people else None

    def in_robot_frame(self, xy):
        """(x, y) in the map seen from the robot's true pose: what a client's detector would give."""
        return tuple(float(v) for v in pose2d.transform_points(pose2d.inverse(self.pose()), [xy])[0])

    def tracked_near(self, xy, radius=0.4):
        """The persistent id of whom the tracker's latest message has within ``radius`` of ``xy``
        (map), placed through the robot's odometry and true poses (as people_metrics compares), or
        None."""
        with self.lock:
            if not (self.tracks and self.odom and self.truth):
                return None
            tracks, odom, truth = self.tracks[-1][1], self.odom[-1][1:], self.truth[-1][1:]
        for pid, p in tracks.items():
            local = pose2d.transform_points(pose2d.inverse(odom), [p])[0]
            if np.hypot(*(pose2d.transform_points(truth, [local])[0] - np.asarray(xy))) <= radius:
                return pid
        return None

    def filtered_has(self, pid):
        """Whether filter_user_tracker's latest message has the persistent id ``pid``."""
        with self.lock:
            return bool(self.filtered) and pid in self.filtered[-1][1]

    def remove_person(self, pid):
        from florence_sim.srv import RemovePerson

        self._call("remove_person", RemovePerson, pid)

    # --- goals -------------------------------------------------------------------------------------
    def follow(self, pid, max_lin_speed=0.0, max_ang_speed=0.0, distance=0.0):
        """Send a FollowMe goal at the person ``pid``'s position in the robot frame."""
        from follow_me.msg import FollowMeGoal

        x, y = self.in_robot_frame(self.person(pid))
        self.follow_client.send_goal(FollowMeGoal(x, y, max_lin_speed, max_ang_speed, distance),
                                     feedback_cb=lambda fb: self._on_feedback("follow_me", fb))

    def approach(self, pid, distance=0.0, p2r=0.0, r2p=0.0, max_lin_speed=0.0, max_ang_speed=0.0):
        from approach_me.msg import ApproachMeGoal

        x, y = self.in_robot_frame(self.person(pid))
        self.approach_client.send_goal(ApproachMeGoal(x, y, distance, p2r, r2p, max_lin_speed, max_ang_speed),
                                       feedback_cb=lambda fb: self._on_feedback("approach_me", fb))

    def _on_feedback(self, name, fb):
        with self.lock:
            self.feedback.append((self.sim_now(), name, fb.x, fb.y))

    def wait_result(self, client, sim_timeout):
        """Wait until the goal ends (and the recorders reach the simulator's present: catch_up) or
        ``sim_timeout`` simulated seconds pass (a wall backstop when the simulation stalls); returns
        (state name, text)."""
        start = self.sim_now()
        deadline = time.monotonic() + 20.0 * sim_timeout + 60.0
        while time.monotonic() < deadline:
            state = client.get_state()
            if state not in (GoalStatus.PENDING, GoalStatus.ACTIVE):
                self.catch_up()
                return STATE_NAMES.get(state, str(state)), client.get_goal_status_text()
            if self.sim_now() - start > sim_timeout:
                return "TIMEOUT", f"no result after {sim_timeout:.0f} s of simulated time"
            time.sleep(0.02)
        return "TIMEOUT", "no result in wall time (simulation stalled?)"

    def wait_still(self, sim_time=0.5, timeout=60.0, v=0.01, w=0.01):
        """Wait (wall ``timeout``) until the robot's true speeds stayed within ``v`` [m/s] and ``w``
        [rad/s] for ``sim_time`` simulated seconds; False if it did not come to rest."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.still(sim_time, v, w):
                return True
            time.sleep(0.02)
        return False

    def still(self, sim_time=0.5, v=0.01, w=0.01):
        """Whether the robot's true speeds stayed within ``v`` [m/s] and ``w`` [rad/s] for the last
        ``sim_time`` simulated seconds."""
        track = self.truth_log(self.sim_now() - sim_time)
        if len(track) <= 2 or track[-1, 0] - track[0, 0] < 0.9 * sim_time:
            return False
        dt = np.maximum(np.diff(track[:, 0]), 1e-6)
        speed = np.hypot(*np.diff(track[:, 1:3], axis=0).T) / dt
        turn = np.abs(np.diff(np.unwrap(track[:, 3]))) / dt
        return bool(np.all(speed <= v) and np.all(turn <= w))

    def wait_tracked(self, pid, timeout=20.0):
        """Wait (simulated ``timeout``) until the tracker has the person ``pid`` and the filter passes
        them on (what follow_me reads); whether it does."""
        start = self.sim_now()

        def seen():
            tid = self.tracked_near(self.person(pid))
            return tid is not None and self.filtered_has(tid)

        wait_for(lambda: seen() or self.sim_now() - start > timeout, 20 * timeout + 30, what=f"{pid} tracked")
        return seen()

    # --- scenes and trials -------------------------------------------------------------------------------
    def scene(self, robot, **people):
        """Nobody but ``people`` (id -> people-file spec), the robot carried to ``robot`` (amcl told),
        the tracker restarted (~Stop, ~Start) and every person tracked; returns the simulated time."""
        from user_tracker_ni.srv import Start, Stop

        for client in (self.follow_client, self.approach_client):
            client.cancel_all_goals()
        self.stop()
        rospy.ServiceProxy("/user_tracker_ni_node/Stop", Stop)()
        self.remove_people()
        self.set_robot(*robot)
        for pid, spec in people.items():
            self.set_person(pid, **spec)
        self.wait_sim(1.5)  # amcl takes the new pose, the laser the free floor
        if not rospy.ServiceProxy("/user_tracker_ni_node/Start", Start)().success:
            raise RuntimeError("user_tracker_ni_node did not start")
        for pid in people:
            if not self.wait_tracked(pid):
                raise RuntimeError(f"{pid} not tracked")
        return self.sim_now()

    def follow_trial(self, robot, pid, path, speed, shirt, desired=1.0, close_in=10.0, settle=15.0):
        """FollowMe behind ``pid`` standing at ``path[0]`` with the robot at ``robot``: the goal; once the
        robot stands within START_TOLERANCE of ``desired`` behind them (at most ``close_in`` s), the
        person walks ``path`` once at ``speed`` [m/s]; ended when the robot settled within 0.2 m of
        ``desired`` behind them after they arrived (at most ``settle`` s later). The goal is left
        running. Returns the measures, the users user_tracker_ni dropped meanwhile by reason (its
        /diagnostics) (enablers_metrics.following, from the walk's start; a fixed 2 s
        left the robot 0.11-0.14 m short of settled, a lag the walk at its top speed never made up),
        the distance at the walk's start, the goal's state, the collisions and the tracks; and the RMS
        error a perfect follower would have had, seeing the person IDEAL_DELAYS late, driving straight at
        them and (``ideal_trail_rms_error_m``) on their trail (enablers_metrics.ideal_following)."""
        from florence_eval import enablers_metrics

        heading = math.atan2(path[1][1] - path[0][1], path[1][0] - path[0][0])
        t0 = self.scene(robot, **{pid: {"pose": [*path[0], heading], "shirt": shirt}})
        collisions = self.collisions
        self.follow(pid, distance=desired)
        start = self.sim_now()
        wait_for(lambda: (abs(math.dist(self.pose()[:2], self.person(pid)) - desired) < START_TOLERANCE
                          and self.still()) or self.sim_now() - start > close_in,
                 20 * close_in + 60, what="the robot closing in behind the person")
        start_distance = math.dist(self.pose()[:2], self.person(pid))
        with self.lock:
            drops = dict(self.tracker_drops)
        self.set_person(pid, path=[list(p) for p in path], speed=speed, mode="once", shirt=shirt)
        walk = self.sim_now()
        self.wait_sim(sum(math.dist(a, b) for a, b in itertools.pairwise(path)) / speed)
        arrived = self.sim_now()
        wait_for(lambda: abs(math.dist(self.pose()[:2], self.person(pid)) - desired) < 0.2
                 or self.sim_now() - arrived > settle, 20 * settle + 60, what="the robot settling behind")
        self.wait_still(timeout=60)
        end = self.sim_now()
        self.wait_sim(DIAGNOSTICS_WAIT)
        robot_log, person_log = self.truth_log(walk), self.person_log(pid, walk)
        result = enablers_metrics.following(robot_log, person_log, self.feedback_log("follow_me", walk),
                                            self.states_log("follow_me", t0), desired, walk, end)
        ideal, trail = ({f"{delay:.1f}_s": enablers_metrics.ideal_following(
            person_log, robot_log[0, 1:3], desired, walk, end, delay=delay, along_trail=along)["rms_error_m"]
            for delay in IDEAL_DELAYS} for along in (False, True))
        return {**result, "ideal_rms_error_m": ideal, "ideal_trail_rms_error_m": trail,
                "start_distance_m": start_distance,
                "state": STATE_NAMES.get(self.follow_client.get_state()),
                "text": self.follow_client.get_goal_status_text(), "collisions": self.collisions - collisions,
                "final_distance_m": math.dist(self.pose()[:2], self.person(pid)), "walk_s": arrived - walk,
                "tracker_drops": self.drops_since(drops),
                "robot_track": robot_log[robot_log[:, 0] <= end][::5].round(3).tolist(),
                "person_track": person_log[person_log[:, 0] <= end][::5].round(3).tolist()}

    def approach_trial(self, robot, pid, person, shirt, distance, p2r, r2p, timeout=60.0):
        """ApproachMe to ``pid`` standing at ``person`` with the robot at ``robot``; judged by ground truth
        (enablers_metrics.approach_errors) once the robot is at rest. Returns the measures."""
        from florence_eval import enablers_metrics

        heading = math.atan2(robot[1] - person[1], robot[0] - person[0])  # facing the robot
        t0 = self.scene(robot, **{pid: {"pose": [*person, heading], "shirt": shirt}})
        collisions, robot0, person0 = self.collisions, self.pose(), self.person(pid)
        self.approach(pid, distance=distance, p2r=p2r, r2p=r2p)
        state, text = self.wait_result(self.approach_client, timeout)
        self.wait_still(timeout=60)
        pos, head = enablers_metrics.approach_errors(self.pose(), person0, robot0[:2], self.person(pid), distance,
                                                     p2r, r2p)
        goal = enablers_metrics.approach_target(person0, robot0[:2], distance, p2r)
        track = self.truth_log(t0)
        least = (float(np.min(np.hypot(track[:, 1] - person0[0], track[:, 2] - person0[1]))) if len(track)
                 else math.nan)
        return {"state": state, "text": text, "position_error_m": pos, "heading_error_rad": head,
                "collisions": self.collisions - collisions, "seconds": self.sim_now() - t0,
                "least_distance_m": least, "robot": list(robot0), "person": list(person0), "goal": list(goal),
                "distance": distance, "p2r": p2r, "r2p": r2p, "robot_track": track[::5].round(3).tolist(),
                "monitor_held": self.monitor_held(t0, track) if state != "SUCCEEDED" else None}

    def monitor_held(self, since, track):
        """The collision monitor's first judgement since ``since`` that slowed or stopped a command, with the
        point that made it (placed in the map through the robot's true pose ``track`` rows (t, x, y, yaw)):
        {"t", "state", "reason", "nearest": [x, y]}; None when it held nothing back. A bench stop 54 had to
        probe for: a failed approach's "no progress" was a phantom where the world has nothing."""
        with self.lock:
            held = next((r for r in self.monitor if r[0] >= since and r[1] in ("slow", "stop", "blind")), None)
        if held is None or not len(track):
            return None
        k = min(int(np.searchsorted(track[:, 0], held[0])), len(track) - 1)
        nearest = pose2d.transform_points(track[k, 1:4], [held[5:7]])[0].round(3).tolist()
        return {"t": round(held[0], 2), "state": held[1], "reason": held[4], "nearest": nearest}

    # --- logs ------------------------------------------------------------------------------------------
    def truth_log(self, since=0.0, until=np.inf):
        """Rows (t, x, y, yaw) of the robot's true pose stamped in [since, until]."""
        with self.lock:
            rows = [r for r in self.truth if since <= r[0] <= until]
        return np.array(rows).reshape(-1, 4)

    def person_log(self, pid, since=0.0, until=np.inf):
        """Rows (t, x, y) of a person's true position."""
        with self.lock:
            rows = [(t, *people[pid]) for t, people in self.people if since <= t <= until and pid in people]
        return np.array(rows).reshape(-1, 3)

    def commands_log(self, where, since=0.0):
        with self.lock:
            return [r for r in self.commands[where] if r[0] >= since]

    def states_log(self, name, since=0.0):
        with self.lock:
            return [r for r in self.states[name] if r[0] >= since]

    def feedback_log(self, name, since=0.0):
        with self.lock:
            return [(t, x, y) for t, n, x, y in self.feedback if n == name and t >= since]

    def monitor_log(self, since=0.0):
        with self.lock:
            return [r for r in self.monitor if r[0] >= since]

    def teleop(self, v, w, seconds, period=0.05):
        """Teleop (v, w) for ``seconds`` of simulated time on the multiplexer's teleop input, then a stop."""
        self.drive(v, w, seconds, period)
