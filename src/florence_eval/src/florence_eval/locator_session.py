"""florenceLocator on the whole stack in florence_sim, scripted and recorded (tests and
bench/locator.py).

:func:`launch_stack` starts what the robot runs: ``turtlebot_2dnav_control.launch sim:=true``
(florence_sim, filters, multiplexer, map_server, amcl, move_base; by default without its people
layers, with ``user_tracker.launch`` apart) and
``florence_locator.launch`` (florence_locator_node, detect_users_node, approach_me_map_node), one
after the other (roslaunches started at once race for /run_id). :class:`LocatorSession` calls the
florenceLocator services as a client would, scripts the scene through florence_sim's services
(people_session.PeopleSession) and records the ground truth it is judged by: the robot's true
pose and speed, the people's poses and postures, the bumpers' collisions.
"""

import math
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import rosgraph
import rospy
from nav_msgs.msg import Odometry
from std_msgs.msg import Bool, UInt32

from detect_users.msg import DetectedUser
from florence_common.maps import map_file
from florence_common.processes import roslaunch, wait_for
from florence_common_ros.convert import to_xyyaw
from florence_eval.people_session import PeopleSession, _registered

ROOMS = map_file("apartment", "rooms.yaml")


def launch_stack(master, start, real_time_factor=2.0, seed=1, people=None, hotspots=None, people_layers=True):
    """Start the navigation stack with florence_sim (``people``: a people file, None: nobody), the user
    tracker and the locator's nodes against ``master``; the robot (and amcl) at ``start`` (x, y, yaw).
    ``hotspots``: the locator's hotspots file (None: a copy of florence_locator's, in a temporary
    folder, so that setHotspot never writes the shipped one). ``people_layers``: move_base with its
    people layers and the tracker from the navigation launch (the shipped configuration); False:
    without them and user_tracker.launch apart (as the locator was first built against). Returns the
    processes (the caller stops them, in reverse order)."""
    import rospkg

    folder = Path(tempfile.mkdtemp(prefix="locator-"))
    if people is None:
        people = folder / "nobody.yaml"
        people.write_text("people: []\n")
    if hotspots is None:
        hotspots = folder / "hotspots.yaml"
        shutil.copy(Path(rospkg.RosPack().get_path("florence_locator")) / "config" / "hotspots.yaml", hotspots)
    x, y, yaw = start
    graph = rosgraph.Master("/launch_stack", master_uri=master.uri)
    procs = []

    def started(proc, node):
        wait_for(lambda: not proc.running() or _registered(graph, node), 180, what=f"{node} to start")
        if not proc.running():
            raise RuntimeError(f"{proc.name} exited:\n{proc.output(3000)}")

    try:
        # with move_base's people layers (people_tracking:=true, the shipped default), move_base keeps 0.6 m from
        # people but only approach_person_distance (0.45 m) from the user approach_me_map announces on
        # move_base/approach_target: before that, gotoUser to a user in the bedroom ended ABORTED, move_base
        # oscillating near her until its recoveries gave up (2 runs of 2, load 11-20)
        procs.append(roslaunch(master, "turtlebot_control", "turtlebot_2dnav_control.launch", "sim:=true",
                               f"people:={people}", f"real_time_factor:={real_time_factor}", f"seed:={seed}",
                               f"x:={x}", f"y:={y}", f"yaw:={yaw}", f"people_tracking:={str(people_layers).lower()}"))
        # the first roslaunch sets /run_id; the others, started once it is there, do not race for it
        wait_for(lambda: graph.hasParam("/run_id"), 60, what="roslaunch's /run_id")
        if not people_layers:
            procs.append(roslaunch(master, "user_tracker_ni", "user_tracker.launch"))
        procs.append(roslaunch(master, "florence_locator", "florence_locator.launch", f"rooms_file:={ROOMS}",
                               f"hotspots_file:={hotspots}"))
        for proc, node in ((procs[0], "/move_base"), (procs[-2], "/user_tracker_ni_node"),
                           (procs[-1], "/approach_me_map_node")):
            started(proc, node)
    except Exception:
        for proc in reversed(procs):
            print(f"----- {proc.name} -----\n{proc.output(3000)}")
            proc.stop()
        raise
    return procs


def stop_stack(procs):
    """Stop the processes of :func:`launch_stack` at once (each roslaunch takes seconds to stop its nodes)."""
    import threading

    threads = [threading.Thread(target=proc.stop) for proc in procs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()


class LocatorSession(PeopleSession):
    """A client of florenceLocator plus the recorders the runs are judged by."""

    def __init__(self):
        from florence_sim.msg import People

        super().__init__(cmd_vel="/cmd_vel_mux/input/teleop")
        self.motion = []  # (t, x, y, yaw, v [m/s], w [rad/s]) of the robot (ground truth)
        self.poses = []  # (t, {id: (x, y, yaw, posture)}) of the people (ground truth)
        self.collisions = 0
        self.override = rospy.Publisher("/florenceLocator/manualOverride", Bool, queue_size=1, latch=True)
        self.pubs.append(self.override)
        self._proxies = {}
        self.detections = []  # simulated times of detect_users' /detected_user (command true)
        self.subs += [
            rospy.Subscriber("/detected_user", DetectedUser, self._on_detected, queue_size=5),
            rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on_motion, queue_size=100),
            rospy.Subscriber("/people_ground_truth", People, self._on_people_states, queue_size=20),
            rospy.Subscriber("/collisions", UInt32, self._on_collisions, queue_size=5),
        ]

    # --- recorders -----------------------------------------------------------------------------------------------
    def _on_motion(self, msg):
        x, y, yaw = to_xyyaw(msg)
        t = msg.twist.twist
        with self.lock:
            self.motion.append((msg.header.stamp.to_sec(), x, y, yaw, math.hypot(t.linear.x, t.linear.y), t.angular.z))

    def _on_people_states(self, msg):
        states = {p.id: (*to_xyyaw(p.pose), p.posture) for p in msg.people}
        with self.lock:
            self.poses.append((msg.header.stamp.to_sec(), states))

    def _on_detected(self, msg):
        if msg.command:
            with self.lock:
                self.detections.append(self.motion[-1][0] if self.motion else 0.0)

    def detected_since(self, since):
        """Simulated time of the first detection at or after ``since``, or None."""
        with self.lock:
            return next((t for t in self.detections if t >= since), None)

    def _on_collisions(self, msg):
        with self.lock:
            self.collisions = msg.data

    def track(self, since=-math.inf):
        with self.lock:
            rows = [r for r in self.motion if r[0] >= since]
        return np.array(rows).reshape(-1, 6)

    def people_log(self, since=-math.inf):
        with self.lock:
            return [p for p in self.poses if p[0] >= since]

    def robot(self):
        """The robot's latest true pose (x, y, yaw)."""
        with self.lock:
            return self.motion[-1][1:4] if self.motion else None

    def person(self, pid):
        """The latest true (x, y, yaw, posture) of person ``pid``, or None."""
        with self.lock:
            return self.poses[-1][1].get(pid) if self.poses else None

    # --- florenceLocator -------------------------------------------------------------------------------------------
    def call(self, name, *args):
        """Call /florenceLocator/<name> (its .srv type is named after it) and return the response."""
        from florence_locator import srv

        proxy = self._proxies.get(name)
        if proxy is None:
            rospy.wait_for_service(f"/florenceLocator/{name}", 60)
            proxy = self._proxies[name] = rospy.ServiceProxy(f"/florenceLocator/{name}",
                                                             getattr(srv, name[0].upper() + name[1:]))
        return proxy(*args)

    def wait_status(self, states, sim_timeout, wall_timeout=None):
        """Wait until getStatus is one of ``states`` (or ``sim_timeout`` simulated seconds pass), and
        the recorders reach the simulator's present (catch_up); returns the response (its status
        "TIMEOUT" on a timeout)."""
        start = self.sim_now()
        deadline = time.monotonic() + (wall_timeout or 20 * sim_timeout + 60)
        while time.monotonic() < deadline:
            res = self.call("getStatus")
            if res.status in states:
                self.catch_up()
                return res
            if self.sim_now() - start > sim_timeout:
                break
            time.sleep(0.1)
        res.status = "TIMEOUT"
        res.message = f"no end after {self.sim_now() - start:.0f} simulated s: {res.message}"
        return res

    def goto_user(self, sim_timeout=240.0):
        """gotoUser and its end: (response of the call, final getStatus, simulated seconds)."""
        t0 = self.sim_now()
        res = self.call("gotoUser")
        if not res.success:
            return res, None, 0.0
        done = self.wait_status({"SUCCEEDED", "ABORTED", "PREEMPTED", "REJECTED", "RECALLED", "LOST"}, sim_timeout)
        return res, done, self.sim_now() - t0

    def wait_ready(self, timeout=180.0):
        """Until the locator answers, the simulation runs and amcl has placed the robot on the map."""
        wait_for(lambda: self.sim_now() > 2.0, timeout, what="florence_sim's clock")
        rospy.wait_for_service("/florenceLocator/gotoUser", timeout)
        wait_for(lambda: self.call("getRobotPosRoom").success, timeout, what="the locator to see the robot (amcl)")

    def place_robot(self, pose, tolerance=0.3, attempts=3):
        """Carry the robot to ``pose`` (x, y, yaw) and tell amcl, until the locator's getRobotPosXYPhi
        agrees within ``tolerance`` [m] (amcl takes an initial pose with its next scan update); then
        what the monitor and move_base kept is cleared once more (a frame taken before the carry may
        have come in after the first clearing)."""
        for _ in range(attempts):
            self.set_robot(*pose)
            try:
                wait_for(lambda: (r := self.call("getRobotPosXYPhi")).success
                         and math.hypot(r.x - pose[0], r.y - pose[1]) < tolerance, 20.0,
                         what="amcl to take the robot's new pose")
                self.forget_surroundings()
                return
            except Exception:  # noqa: BLE001 - tell it again
                continue
        raise RuntimeError(f"amcl did not take the pose {pose} in {attempts} attempts")

    def set_override(self, on):
        self.override.publish(Bool(on))
