"""A people tracker in florence_sim, recorded and scripted for its evaluation (tests and
bench/people.py).

Runs inside a rospy node that the caller initialised, against a master where florence_sim and
user_tracker_ni run (:func:`launch_stack` starts them, with map_server and amcl: the tracker
checks its detections against the robot's map, placed through amcl as on the robot). It records
the tracker's output, the simulator's people and the robot's true and odometry poses (all stamped
in simulated time), scripts the scene through florence_sim's test services (a robot carried to
another place is given to amcl as its initial pose there, as a user does in rviz), and drives the
robot by cmd_vel.
"""

import threading
import time

import numpy as np
import rosgraph
import rospy
import yaml
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from florence_common.processes import wait_for
from florence_common_ros.convert import to_xyyaw
from florence_eval import people_metrics, sim_now

FORGET = "/collision_monitor/forget"  # std_srvs/Trigger: the monitor drops what it remembers
CLEAR_COSTMAPS = "/move_base/clear_costmaps"  # std_srvs/Empty: move_base's costmaps drop what the sensors marked


def launch_stack(master, start, real_time_factor=1.0, seed=1, people=None, amcl=True, tracker_args=()):
    """Start florence_sim (``people``: a people file, None: nobody), map_server with the apartment's
    map, amcl at ``start`` (x, y, yaw) and user_tracker.launch against ``master``, one after the
    other (roslaunches started at once race for /run_id); returns the processes (the caller stops
    them, in reverse order). ``amcl=False``: no map_server, no amcl (the tracker then works
    without the map check)."""
    import tempfile
    from pathlib import Path

    from florence_common.maps import map_file
    from florence_common.processes import roslaunch, rosrun

    if people is None:
        people = Path(tempfile.mkdtemp(prefix="people-")) / "nobody.yaml"
        people.write_text("people: []\n")
    x, y, yaw = start
    graph = rosgraph.Master("/launch_stack", master_uri=master.uri)
    procs = []

    def started(proc, node):
        procs.append(proc)
        wait_for(lambda: _registered(graph, node), 120, what=f"{node} to start")

    try:
        started(roslaunch(master, "florence_sim", "florence_sim.launch", f"people:={people}",
                          f"real_time_factor:={real_time_factor}", f"seed:={seed}", f"x:={x}", f"y:={y}",
                          f"yaw:={yaw}"), "/florence_sim")
        if amcl:
            started(rosrun(master, "map_server", "map_server", str(map_file("apartment", "apartment.yaml"))),
                    "/map_server")
            started(roslaunch(master, "turtlebot_control", "amcl_turtlebot_control.launch", f"initial_pose_x:={x}",
                              f"initial_pose_y:={y}", f"initial_pose_a:={yaw}"), "/amcl")
        started(roslaunch(master, "user_tracker_ni", "user_tracker.launch", *tracker_args), "/user_tracker_ni_node")
    except Exception:
        for proc in reversed(procs):
            print(f"----- {proc.name} -----\n{proc.output(3000)}")
            proc.stop()
        raise
    return procs


def _registered(graph, node):
    try:
        return bool(graph.lookupNode(node))
    except rosgraph.MasterError:
        return False


class PeopleSession:
    """``filtered_topic``: also record filter_user_tracker's output (which users it kept)."""

    def __init__(self, tracked_topic="/tracked_users", cmd_vel="/cmd_vel", filtered_topic=None,
                 people_topic="/tracked_people"):
        from florence_sim.msg import People
        from user_tracker_ni.msg import TrackedUsers

        self.lock = threading.Lock()
        self.tracks = []  # (t [s], {pid: (x, y) in the tracker's frame}, {pid: ni id})
        self.everyone = []  # the same of people_topic: every confirmed person, by ni id
        self.seen = []  # (t [s], {pid: last_seen [s]}) of the tracker's messages
        self.filtered = []  # (t [s], {pid, ...}) of the filter's messages
        self.people = []  # (t [s], {id: (x, y) in map})
        self.truth = []  # (t, x, y, yaw) in map
        self.odom = []  # (t, x, y, yaw) in odom
        from geometry_msgs.msg import PoseWithCovarianceStamped

        self.cmd = rospy.Publisher(cmd_vel, Twist, queue_size=1)
        self.initialpose = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
        # unregistered by close(): a latched /initialpose left in a test process would place the next
        # test's amcl where this one last carried the robot
        self.pubs = [self.cmd, self.initialpose]
        self.subs = [
            rospy.Subscriber(tracked_topic, TrackedUsers, self._on_tracks, queue_size=50),
            rospy.Subscriber(people_topic, TrackedUsers, self._on_everyone, queue_size=50),
            rospy.Subscriber("/people_ground_truth", People, self._on_people, queue_size=50),
            rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on_pose, callback_args=self.truth,
                             queue_size=100),
            rospy.Subscriber("/odom", Odometry, self._on_pose, callback_args=self.odom, queue_size=100),
        ]
        if filtered_topic:
            self.subs.append(rospy.Subscriber(filtered_topic, TrackedUsers, self._on_filtered, queue_size=50))

    # --- recording ---------------------------------------------------------------------------------
    def _on_tracks(self, msg):
        t = msg.stamp.to_sec()
        tracks = {pid: (p.x, p.y) for pid, p in zip(msg.user_ids, msg.positions, strict=False)}
        ni = dict(zip(msg.user_ids, msg.user_ids_ni, strict=False))
        seen = {pid: s.to_sec() for pid, s in zip(msg.user_ids, msg.last_seen, strict=False)}
        with self.lock:
            self.tracks.append((t, tracks, ni))
            self.seen.append((t, seen))

    def _on_everyone(self, msg):
        with self.lock:
            self.everyone.append((msg.stamp.to_sec(), {i: (p.x, p.y) for i, p in zip(msg.user_ids, msg.positions,
                                                                                     strict=False)},
                                  dict(zip(msg.user_ids, msg.user_ids_ni, strict=False))))

    def _on_filtered(self, msg):
        with self.lock:
            self.filtered.append((msg.stamp.to_sec(), set(msg.user_ids)))

    def _on_people(self, msg):
        with self.lock:
            self.people.append((msg.header.stamp.to_sec(),
                                {p.id: (p.pose.position.x, p.pose.position.y) for p in msg.people}))

    def _on_pose(self, msg, store):
        x, y, yaw = to_xyyaw(msg)
        with self.lock:
            store.append((msg.header.stamp.to_sec(), x, y, yaw))

    def close(self):
        self.stop()
        for handle in (*self.subs, *self.pubs):
            handle.unregister()

    def sim_now(self):
        with self.lock:
            return self.truth[-1][0] if self.truth else 0.0

    def catch_up(self, timeout=60.0):
        """Wait until the recorded ground truth reaches the simulator's present (sim_now.py): call it
        before judging an outcome that came by another way (a service, an action result)."""
        return sim_now.catch_up(self.sim_now, timeout)

    def wait_sim(self, seconds, timeout=None):
        """Let ``seconds`` of simulated time pass (wall timeout: 20 x that plus 30 s)."""
        start = self.sim_now()
        wait_for(lambda: self.sim_now() >= start + seconds, timeout or 20 * seconds + 30,
                 what=f"{seconds} s of simulated time")

    def frames(self, since, until, view=None, visible=None, everyone=False):
        """people_metrics.Frame of every tracker message stamped in [since, until] [s]; a person counts
        where the Kinect has them in ``view`` and, by default, in line of sight past the apartment's
        walls and furniture. ``everyone``: of people_topic's messages (every confirmed person)."""
        if visible is None:
            visible = self.line_of_sight()
        with self.lock:
            tracks = [m for m in (self.everyone if everyone else self.tracks) if since <= m[0] <= until]
            people = list(self.people)
            truth = np.array(self.truth).reshape(-1, 4)
            odom = np.array(self.odom).reshape(-1, 4)
        return people_metrics.frames(tracks, people, (truth[:, 0], truth[:, 1:]), (odom[:, 0], odom[:, 1:]),
                                     view or people_metrics.KinectView(), visible)

    def line_of_sight(self):
        if getattr(self, "_line_of_sight", None) is None:
            from florence_sim.world import load_world

            from florence_common.maps import map_file

            world = load_world(str(map_file("apartment", "apartment.world.yaml")))
            self._line_of_sight = people_metrics.LineOfSight(world.scene)
        return self._line_of_sight

    def last_seen_log(self, since, until):
        """[(t, {persistent id: last_seen [s]})] of the tracker's messages stamped in [since, until]."""
        with self.lock:
            return [m for m in self.seen if since <= m[0] <= until]

    def filtered_log(self, since, until):
        """[(t, {persistent id, ...})] of the filter's messages stamped in [since, until]."""
        with self.lock:
            return [m for m in self.filtered if since <= m[0] <= until]

    # --- scripting the scene ----------------------------------------------------------------------------
    @staticmethod
    def _call(name, srv, *args):
        rospy.wait_for_service(f"/florence_sim/{name}", 30)
        res = rospy.ServiceProxy(f"/florence_sim/{name}", srv)(*args)
        if not res.success:
            raise RuntimeError(f"florence_sim/{name}{args}: {res.message}")
        return res

    def set_person(self, pid, **spec):
        """Add or replace a person (a people-file entry without the id: pose, path, posture, shirt ...)."""
        from florence_sim.srv import SetPerson

        self._call("set_person", SetPerson, pid, yaml.safe_dump(spec, default_flow_style=True))

    def remove_people(self):
        from florence_sim.srv import RemovePerson

        with self.lock:
            ids = set(self.people[-1][1]) if self.people else set()
        for pid in ids:
            self._call("remove_person", RemovePerson, pid)

    def set_robot(self, x, y, yaw, initialpose=True):
        """Carry the robot to (x, y, yaw) in the map; with ``initialpose``, tell amcl (/initialpose).
        A collision monitor running forgets what it remembers (~forget), and move_base's costmaps are
        cleared (as whoever carries the real robot does): odometry did not see the carry, so what they
        kept in the odometry frame would stand around the robot where it was put (what the monitor's
        depth memory kept near the robot, a person approached last above and below the Kinect's view,
        for good)."""
        from geometry_msgs.msg import PoseWithCovarianceStamped

        from florence_common_ros.convert import pose_msg
        from florence_sim.srv import SetRobotPose

        self.stop()
        self._call("set_robot_pose", SetRobotPose, x, y, yaw)
        self.forget_surroundings()
        if initialpose:
            msg = PoseWithCovarianceStamped()
            msg.header.frame_id = "map"
            msg.header.stamp = rospy.Time.now()
            msg.pose.pose = pose_msg(x, y, yaw)
            msg.pose.covariance[0] = msg.pose.covariance[7] = 0.01  # [m^2]
            msg.pose.covariance[35] = 0.005  # [rad^2]
            self.initialpose.publish(msg)

    def forget_surroundings(self):
        """The collision monitor's memory and move_base's costmaps cleared, those of them running."""
        from std_srvs.srv import Empty, Trigger

        for name, kind in ((FORGET, Trigger), (CLEAR_COSTMAPS, Empty)):
            try:
                rosgraph.Master("/people_session").lookupService(name)
            except rosgraph.MasterError:
                continue  # not in this stack
            answer = rospy.ServiceProxy(name, kind)()
            if kind is Trigger and not answer.success:
                raise RuntimeError(f"{name}: {answer.message}")

    def drive(self, v, w, seconds, period=0.05):
        """Command (v [m/s], w [rad/s]) for ``seconds`` of simulated time, then stop."""
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = v, w
        end = self.sim_now() + seconds
        deadline = time.monotonic() + 20 * seconds + 30
        while self.sim_now() < end:
            if time.monotonic() > deadline:
                raise RuntimeError(f"driving for {seconds} s of simulated time did not finish")
            self.cmd.publish(cmd)
            time.sleep(period)
        self.stop()

    def stop(self):
        self.cmd.publish(Twist())
