"""The scripted day: the Florence services driven through the system's public interfaces, as the
Florence services would drive them, each step judged against florence_sim's ground truth.

The robot starts in the kitchen. The user (alice, red shirt) sits in the living room; a visitor
(bob, blue shirt) stands in the living room all day, farther from where the robot looks for her. Steps:

1. a home sensor reports the user in the living room: ``setUserPosRoom("living_room")``;
2. bad input: ``gotoRoom("attic")`` and ``setUserPosXYPhi(NaN, ...)`` answer success false with a
   reason, and nothing changes;
3. ``gotoUser``: to the living room, the 45 degree search, the approach to 0.5 m facing the user
   (never the visitor);
4. ``follow_me``: the user stands up and walks to the bedroom; the goal is the tracker's position
   of the user (``filtered_tracked_users``, in base_link through odometry), picked near where
   florenceLocator last knew the user; she sits down there;
5. ``approach_me``: to a place beside the seated user (p2r 35 degrees: her left side);
6. ``gotoRoom("kitchen")``;
7. ``setHotspot``, florence_locator killed (SIGKILL) and started again (rosrun, its parameters still
   on the master), ``getHotspot`` serves the new value;
8. ``manualOverride`` true: go-to calls refused; the person at the keyboard drives
   (turtlebot_teleop_key on a pseudo-terminal, keys typed as a terminal sends them); released, and
   ``gotoRoom("kitchen")`` brings the robot back;
9. the user tracker killed (SIGKILL): ``gotoUser`` is refused saying why, a FollowMe goal ends
   ABORTED at once with the reason (nothing waits on a tracker that is gone).

florence_sim's services (set_person) are the world: they make the user stand, walk and sit. Nothing
else of the simulator is used to drive; its ground truth (base_pose_ground_truth,
people_ground_truth, collisions) only judges.
"""

import contextlib
import itertools
import math
import os
import signal
import time
from dataclasses import dataclass, field

import numpy as np
import rospy
import yaml
from actionlib_msgs.msg import GoalStatus
from florence_eval.locator_session import LocatorSession
from florence_eval.metrics import node_pid
from florence_locator.places import Rooms
from geometry_msgs.msg import PoseWithCovarianceStamped
from std_msgs.msg import String

from florence_common import angles
from florence_common import pose as pose2d
from florence_common.maps import map_file
from florence_common.processes import ManagedProcess, pid_alive, rosrun, wait_for
from florence_common.pty_device import PtyKeyboard
from florence_common_ros.actions import SimpleActionClient
from florence_common_ros.convert import to_xyyaw
from florence_eval import enablers_metrics, locator_metrics
from florence_scenarios import judge
from florence_scenarios.checks import Checks

USER, VISITOR = "alice", "bob"
RED, BLUE = [0.85, 0.10, 0.10], [0.10, 0.30, 0.85]
START = (6.5, 2.5, math.pi)  # [m, m, rad] the kitchen, facing the opening to the living room
USER_SEAT = (3.0, 2.4, 2.8)  # living room, by the dining table, facing west-north-west
VISITOR_POSE = (4.3, 4.9, -2.4)  # the living room's north-east, by the dining table, facing into the room
# the user's walk from her seat to the bedroom: out of the living room's door (x 2.0..2.9 at y 5.5),
# across the corridor, through the bedroom's door (x 1.0..1.9 at y 6.8), to a seat by the east wall
WALK_SPEED = 0.3  # [m/s] an elderly person's
BEDROOM_SEAT = (4.6, 8.4, math.pi)  # the bedroom's open east part, facing west into the room
FOLLOW_DISTANCE = 1.0  # [m]
# beside her: follow_me leaves the robot 1 m south-west of her seat, 54-56 deg to her front-left (she sits facing
# west), so p2r 35 deg asks for a place about 90 deg to her left; 60 deg asked for 114-116 deg, past the 110 deg
# where locator_metrics' "left" ends (a run on 27 Nov ended there, 0.07 m from the asked place, "behind")
APPROACH = {"distance": 0.6, "p2r": math.radians(35), "r2p": 0.0}
NEW_HOTSPOT = ("tv", 1.0, 4.3, math.pi)  # a new labelled place in the living room [m, m, rad]
ROOMS = map_file("apartment", "rooms.yaml")

# tolerances of the checks
USER_DISTANCE, USER_DISTANCE_TOL = 0.5, 0.15  # [m] gotoUser's end: approach_me_map's safe_distance
FACING_TOL = math.radians(20)
APPROACH_POS_TOL, APPROACH_HEADING_TOL = 0.15, math.radians(15)
TERMINAL = {"SUCCEEDED", "ABORTED", "PREEMPTED", "REJECTED", "RECALLED", "LOST"}
# the day's steps in order: name (the demo's --steps) -> Day method
STEPS = {"user_room": "user_in_living_room", "bad_input": "bad_input", "goto_user": "goto_user",
         "follow": "follow_user", "approach": "approach_user", "goto_kitchen": "goto_kitchen",
         "hotspot": "hotspot_survives_restart", "override": "manual_override", "tracker_killed": "tracker_killed"}
STATE_NAMES = {v: k for k, v in vars(GoalStatus).items() if isinstance(v, int) and k.isupper()}


def walk_path(start):
    """The user's way from ``start`` (x, y, yaw: her seat) to BEDROOM_SEAT: first 0.8 m the way she
    faces (the robot that approached her stands to her front-left or front-right), then around the
    dining table's chairs to the living room's door."""
    x, y, yaw = start
    return [[x, y], [x + 0.8 * math.cos(yaw), y + 0.8 * math.sin(yaw)], [1.75, 3.4], [1.75, 4.6], [2.45, 5.2],
            [2.35, 5.9], [1.5, 6.5], [1.45, 7.2], [2.2, 7.45], [3.9, 7.45], list(BEDROOM_SEAT[:2])]


def not_following(states, since, until):
    """[(start, end, text)] [s] of the spans within [since, until] in which follow_me's state (rows
    (t, text) in time order; the latest before ``since`` holds at ``since``) did not say
    "following", with the text that began each: what it did instead, and how long."""
    before = [(since, text) for t, text in states if t <= since][-1:]
    rows = before + [(t, text) for t, text in states if since < t < until] + [(until, "following")]
    spans, start = [], None
    for t, text in rows:
        if not text.startswith("following") and start is None:
            start = (t, text)
        elif text.startswith("following") and start is not None:
            spans.append((start[0], t, start[1]))
            start = None
    return spans


def people_file(path):
    """The day's people file: the user seated in the living room, the visitor standing in its corner."""
    people = {"people": [
        {"id": USER, "pose": list(USER_SEAT), "posture": "sitting", "shirt": RED, "height": 1.63, "build": 0.9},
        {"id": VISITOR, "pose": list(VISITOR_POSE), "shirt": BLUE, "height": 1.86, "build": 1.1},
    ]}
    with open(path, "w") as f:
        yaml.safe_dump(people, f, default_flow_style=None)
    return path


@dataclass
class Step:
    """One step of the day: what was asked, how it ended, how long it took (simulated), how far off."""
    name: str
    request: str
    start: float = 0.0  # [s] simulated
    end: float = 0.0
    outcome: str = ""
    error: str = ""
    data: dict = field(default_factory=dict)

    @property
    def seconds(self):
        return self.end - self.start

    def as_json(self):
        return {"name": self.name, "request": self.request, "start_s": round(self.start, 2),
                "seconds": round(self.seconds, 2), "outcome": self.outcome, "error": self.error, "data": self.data}


class DaySession(LocatorSession):
    """LocatorSession (the florenceLocator client, the ground-truth recorders) plus what the day adds:
    amcl's estimate, the filtered tracks (what follow_me reads), the enablers' action clients, their
    feedback and states."""

    def __init__(self):
        from approach_me.msg import ApproachMeAction
        from follow_me.msg import FollowMeAction

        from user_tracker_ni.msg import TrackedUsers

        super().__init__()
        self.amcl = []  # (t, x, y, yaw) of amcl's estimate in the map
        self.filtered_tracks = []  # (t, {pid: (x, y)}) in the tracker's frame (odom)
        self.follow_feedback = []  # (t, x, y) in the robot frame
        self.follow_states = []  # (t, text) of follow_me_node/state
        self.follow_client = SimpleActionClient("follow_me", FollowMeAction)
        self.approach_client = SimpleActionClient("approach_me", ApproachMeAction)
        self.subs += [
            rospy.Subscriber("/amcl_pose", PoseWithCovarianceStamped, self._on_amcl, queue_size=20),
            rospy.Subscriber("/filtered_tracked_users", TrackedUsers, self._on_filtered_tracks, queue_size=20),
            rospy.Subscriber("/follow_me_node/state", String, self._on_follow_state, queue_size=50),
        ]

    def _on_amcl(self, msg):
        with self.lock:
            self.amcl.append((msg.header.stamp.to_sec(), *to_xyyaw(msg)))

    def _on_filtered_tracks(self, msg):
        with self.lock:
            where = {pid: (p.x, p.y) for pid, p in zip(msg.user_ids, msg.positions, strict=False)}
            self.filtered_tracks.append((msg.stamp.to_sec(), where))

    def _on_follow_state(self, msg):
        now = self.sim_now()  # takes the lock itself (not re-entrant)
        with self.lock:
            self.follow_states.append((now, msg.data))

    def on_follow_feedback(self, fb):
        now = self.sim_now()
        with self.lock:
            self.follow_feedback.append((now, fb.x, fb.y))

    def wait_enablers(self, timeout):
        for client in (self.follow_client, self.approach_client):
            if not client.wait_for_server(rospy.Duration(timeout)):
                raise RuntimeError(f"no action server {client.action_client.ns}")

    def odom_pose(self):
        with self.lock:
            return self.odom[-1][1:] if self.odom else None

    def latest_tracks(self, filtered=True):
        """{pid: (x, y)} of the tracker's latest message (filter_user_tracker's, or the tracker's own), odom frame."""
        with self.lock:
            if filtered:
                return dict(self.filtered_tracks[-1][1]) if self.filtered_tracks else {}
            return dict(self.tracks[-1][1]) if self.tracks else {}

    def amcl_log(self):
        with self.lock:
            return np.array(self.amcl).reshape(-1, 4)

    def follow_log(self, since):
        with self.lock:
            return ([r for r in self.follow_feedback if r[0] >= since],
                    [r for r in self.follow_states if r[0] >= since])


class Day:
    """Runs the steps in order; every step is recorded (Step) and judged (checks named after it). A
    step that fails or raises is recorded as failed and the day goes on."""

    def __init__(self, session, master, processes, hotspots_file, meter=None, timeout=120.0, steps="all",
                 print_fn=print):
        self.s = session
        self.master = master
        self.processes = processes
        self.hotspots_file = hotspots_file
        self.meter = meter
        self.timeout = timeout  # [s, wall] start-up waits
        self.print = print_fn
        self.steps = []
        self.calls = []  # every florenceLocator call: (t, service, args, success, message)
        self.checks = Checks()
        self.follow = {}  # the following's series for the report
        self.result_xy = None  # follow_me's result: the user in base_link when it was cancelled
        self.rooms = Rooms.load(str(ROOMS))
        self.t0 = session.sim_now()
        self.selected = list(STEPS) if steps == "all" else [name.strip() for name in steps.split(",") if name.strip()]
        unknown = [name for name in self.selected if name not in STEPS]
        if unknown:
            raise ValueError(f"unknown steps {unknown}: the day's steps are {', '.join(STEPS)}")

    # --- helpers -----------------------------------------------------------------------------------------
    def log(self, text):
        self.print(f"day [sim {self.s.sim_now() - self.t0:6.1f} s] {text}", flush=True)

    def check(self, name, passed, detail=""):
        self.checks.add(name, passed, detail)
        self.log(f"  {'PASSED' if passed else 'FAILED'} {name}: {detail}")
        return passed

    def call(self, service, *args):
        t = self.s.sim_now()
        res = self.s.call(service, *args)
        self.calls.append({"t": round(t - self.t0, 2), "service": service, "args": [_short(a) for a in args],
                           "success": bool(getattr(res, "success", True)), "message": getattr(res, "message", "")})
        self.log(f"florenceLocator/{service}{tuple(_short(a) for a in args)} -> success {res.success}: {res.message}")
        return res

    @contextlib.contextmanager
    def step(self, name, request):
        step = Step(name, request, start=self.s.sim_now())
        self.steps.append(step)
        self.log(f"== {name}: {request}")
        collisions = self.s.collisions
        try:
            yield step
        except Exception as exc:  # noqa: BLE001 - recorded, and the day goes on
            step.outcome = step.outcome or "FAILED"
            step.error = f"{type(exc).__name__}: {exc}"
            self.check(f"{name}: ran to its end", False, step.error)
        finally:
            step.end = self.s.sim_now()
            bumps = self.s.collisions - collisions
            step.data["collisions"] = bumps
            self.check(f"{name}: no collision", bumps == 0, f"{bumps} collision(s) (ground truth)")
            self.log(f"== {name}: {step.outcome} in {step.seconds:.1f} simulated s; {step.error}")

    def wall_limit(self, sim_seconds):
        """A wall-clock backstop for ``sim_seconds`` of simulated time on a loaded machine."""
        return 4.0 * sim_seconds + 60.0

    def truth_room(self):
        x, y, _ = self.s.robot()
        return self.rooms.room_at(x, y)

    def user(self):
        return self.s.person(USER)

    # --- the steps ---------------------------------------------------------------------------------------
    def run(self):
        self.log(f"the day starts: robot at {tuple(round(v, 2) for v in self.s.robot())}, user {USER} seated at "
                 f"{USER_SEAT[:2]}, visitor {VISITOR} at {VISITOR_POSE[:2]}")
        for name, method in STEPS.items():
            if name in self.selected:
                getattr(self, method)()
        return self.steps, self.checks

    def user_in_living_room(self):
        with self.step("setUserPosRoom", 'setUserPosRoom("living_room"): a home sensor saw the user there') as st:
            res = self.call("setUserPosRoom", "living_room")
            room = self.call("getUserPosRoom")
            st.outcome = "success" if res.success else "refused"
            st.error = f"getUserPosRoom: {room.room}"
            self.check("setUserPosRoom: accepted, getUserPosRoom says living_room",
                       res.success and room.room == "living_room", f"{res.message}; {room.room}")

    def bad_input(self):
        with self.step("bad input", 'gotoRoom("attic"), setUserPosXYPhi(NaN, 2, 0)') as st:
            before = self.call("getUserPosXYPhi")
            attic = self.call("gotoRoom", "attic")
            nan = self.call("setUserPosXYPhi", math.nan, 2.0, 0.0)
            after = self.call("getUserPosXYPhi")
            status = self.call("getStatus")
            st.outcome = f"attic: {attic.success}, NaN: {nan.success}"
            st.error = f"user kept at ({after.x:.2f}, {after.y:.2f})"
            self.check('gotoRoom("attic"): success false with a reason', not attic.success and attic.message,
                       attic.message)
            self.check("setUserPosXYPhi(NaN): success false with a reason", not nan.success and nan.message,
                       nan.message)
            self.check("bad input changed nothing; the locator answers on",
                       (after.x, after.y) == (before.x, before.y) and status.success is not False
                       and not math.isnan(after.x), f"user ({after.x:.2f}, {after.y:.2f}); getStatus {status.status}")

    def goto_user(self):
        with self.step("gotoUser", "gotoUser: to the user's room, search in 45 degree steps, approach to 0.5 m") as st:
            res = self.call("gotoUser")
            if not res.success:
                st.outcome = "refused"
                self.check("gotoUser: SUCCEEDED", False, res.message)
                return
            done = self.s.wait_status(TERMINAL, 240.0, wall_timeout=self.wall_limit(240.0))
            if done.status == "TIMEOUT":
                self.stop_activity()
            self.s.wait_sim(0.5)  # at rest, the pose recorded
            st.outcome = done.status
            user, visitor, robot = self.user(), self.s.person(VISITOR), self.s.robot()
            a = locator_metrics.approach(robot, user)
            to_visitor = math.hypot(visitor[0] - robot[0], visitor[1] - robot[1])
            known = self.call("getUserPosXYPhi")
            st.error = (f"{a.distance:.2f} m from the user (asked {USER_DISTANCE}), facing off "
                        f"{math.degrees(a.facing_error):.0f} deg, at her {a.side_name}; visitor {to_visitor:.2f} m")
            st.data.update(a.as_dict(), visitor_m=round(to_visitor, 3), robot=[round(v, 3) for v in robot])
            self.check("gotoUser: SUCCEEDED", done.status == "SUCCEEDED", f"{done.status}: {done.message}")
            self.check(f"gotoUser: {USER_DISTANCE} +/- {USER_DISTANCE_TOL} m from the user",
                       abs(a.distance - USER_DISTANCE) <= USER_DISTANCE_TOL, f"{a.distance:.3f} m")
            self.check("gotoUser: facing the user within 20 deg", abs(a.facing_error) <= FACING_TOL,
                       f"{math.degrees(a.facing_error):.1f} deg")
            self.check("gotoUser: the user, not the visitor (the visitor > 1 m off, the user nearer)",
                       to_visitor > 1.0 and a.distance < to_visitor,
                       f"user {a.distance:.2f} m, visitor {to_visitor:.2f} m")
            self.check("gotoUser: getUserPosXYPhi within 0.3 m of the user (what detect_users saw)",
                       known.success and math.hypot(known.x - user[0], known.y - user[1]) <= 0.3,
                       f"({known.x:.2f}, {known.y:.2f}) vs truth ({user[0]:.2f}, {user[1]:.2f})")

    def _user_track_in_base(self, near_map, min_range, timeout):
        """Wait (simulated ``timeout``) for a person in filter_user_tracker's output within 1 m of
        ``near_map`` (x, y in the map) and at least ``min_range`` from the robot; returns their (x, y)
        in base_link (through the locator's map pose and odometry) or None."""
        start = self.s.sim_now()
        while self.s.sim_now() - start < timeout:
            robot_map = self.call_quiet("getRobotPosXYPhi")
            odom = self.s.odom_pose()
            if robot_map.success and odom is not None:
                map_from_odom = pose2d.compose((robot_map.x, robot_map.y, robot_map.phi), pose2d.inverse(odom))
                near = pose2d.transform_points(pose2d.inverse(map_from_odom), [near_map])[0]
                best = None
                for xy in self.s.latest_tracks().values():
                    d = math.dist(xy, near)
                    base = pose2d.transform_points(pose2d.inverse(odom), [xy])[0]
                    if d <= 1.0 and math.hypot(*base) >= min_range and (best is None or d < best[0]):
                        best = (d, base)
                if best is not None:
                    return float(best[1][0]), float(best[1][1])
            time.sleep(0.1)
        return None

    def _tracks_seen(self):
        """What the tracker and its filter said last, and how long ago, with the user's true place
        in the robot's frame: why no track was taken."""
        now, robot, user = self.s.sim_now(), self.s.robot(), self.user()
        her = pose2d.transform_points(pose2d.inverse(robot), [user[:2]])[0]
        with self.s.lock:
            last = {"tracker": self.s.tracks[-1][0] if self.s.tracks else None,
                    "filter": self.s.filtered_tracks[-1][0] if self.s.filtered_tracks else None}
        ages = ", ".join(f"{k} {now - t:.1f} s ago" if t is not None else f"{k} never" for k, t in last.items())
        return (f"tracks {self.s.latest_tracks(filtered=False)} (odom), filtered {self.s.latest_tracks()}; "
                f"last messages: {ages}; the user at ({her[0]:.2f}, {her[1]:.2f}) in base_link (ground truth)")

    def call_quiet(self, service, *args):
        return self.s.call(service, *args)

    def follow_user(self):
        with self.step("follow_me", "the user walks to the bedroom; FollowMe at her tracked position, 1.0 m") as st:
            seat = self.user()
            known = self.call("getUserPosXYPhi")
            path = walk_path(seat[:3])
            # the world: she stands up and steps away from her seat, then says "follow me" (the goal), then walks
            self.s.set_person(USER, pose=list(seat[:3]), shirt=RED, height=1.63, build=0.9)
            self.s.wait_sim(1.0)
            self.s.set_person(USER, path=path[:2], speed=WALK_SPEED, mode="once", shirt=RED, height=1.63, build=0.9)
            walk = self.s.sim_now()
            wait_for(lambda: math.dist(self.user()[:2], path[1]) < 0.05 or self.s.sim_now() - walk > 10.0,
                     self.wall_limit(10.0), what="the user's first step")
            goal_xy = self._user_track_in_base((known.x, known.y), 0.7, 8.0)
            if goal_xy is None:
                st.outcome = "no goal"
                st.data["judged_from"] = self.s.sim_now()  # no goal, no driving: the approach's end is not held here
                self.check("follow_me: the user tracked as she set off", False, self._tracks_seen())
                return
            from follow_me.msg import FollowMeGoal

            self.log(f"FollowMe goal at ({goal_xy[0]:.2f}, {goal_xy[1]:.2f}) in base_link")
            self.s.follow_client.send_goal(FollowMeGoal(goal_xy[0], goal_xy[1], 0.0, 0.0, FOLLOW_DISTANCE),
                                           feedback_cb=self.s.on_follow_feedback)
            goal_t = st.data["judged_from"] = self.s.sim_now()  # the robot drives from here
            # she walks on once follow_me has her (its state says "following"), or after 5 s
            wait_for(lambda: any(text.startswith("following") for _, text in self.s.follow_log(goal_t)[1])
                     or self.s.sim_now() - goal_t > 5.0 or self._follow_ended(), self.wall_limit(5.0),
                     what="follow_me following")
            self.s.set_person(USER, path=path[1:], speed=WALK_SPEED, mode="once", shirt=RED, height=1.63, build=0.9)
            length = sum(math.dist(a, b) for a, b in itertools.pairwise(path))
            end_xy, walk_limit = path[-1], length / WALK_SPEED + 20.0  # [s] simulated
            wait_for(lambda: math.dist(self.user()[:2], end_xy) < 0.05 or self.s.sim_now() - walk > walk_limit
                     or self._follow_ended(), self.wall_limit(walk_limit), what="the user's walk")
            arrived = self.s.sim_now()
            # she sits down facing into the room; the robot settles behind her
            self.s.set_person(USER, pose=list(BEDROOM_SEAT), posture="sitting", shirt=RED, height=1.63, build=0.9)
            wait_for(lambda: self.s.sim_now() - arrived > 4.0 or self._follow_ended(), self.wall_limit(4.0),
                     what="the robot settling")
            state_before_cancel = STATE_NAMES.get(self.s.follow_client.get_state())
            self.s.follow_client.cancel_goal()
            wait_for(self._follow_ended, 30.0, what="follow_me's end after the cancel")
            result = self.s.follow_client.get_result()
            self.s.catch_up()
            self.s.wait_sim(1.0)
            track, people = self.s.track(walk), self.s.people_log(walk)
            t, d = judge.distance_series(track, judge.person_rows(people, USER))
            fb, states = self.s.follow_log(walk)
            for since, until, text in not_following(states, goal_t, arrived):
                self.log(f"follow_me not following from {since - self.t0:.1f} to {until - self.t0:.1f} s: {text}")
            measures = enablers_metrics.following(track[:, :4], judge.person_rows(people, USER), fb, states,
                                                  FOLLOW_DISTANCE, goal_t, arrived)
            st.outcome = f"{state_before_cancel} until cancelled"
            self.follow = {"t": (t - self.t0).tolist(), "d": d.tolist(), "walk_s": walk - self.t0,
                           "arrived_s": arrived - self.t0, "desired": FOLLOW_DISTANCE}
            self.result_xy = (result.x, result.y) if result is not None else None
            robot = self.s.robot()
            st.error = (f"distance {np.min(d, initial=math.inf):.2f}-{np.max(d, initial=0.0):.2f} m "
                        f"(asked {FOLLOW_DISTANCE}), "
                        f"RMS error {measures.get('rms_error_m', math.nan):.2f} m, right person "
                        f"{100 * measures.get('kept_fraction', 0):.0f} % of the walk")
            st.data.update({k: round(v, 3) if isinstance(v, float) else v for k, v in measures.items()},
                           walk_m=round(length, 2), final_room=self.truth_room())
            self.check("follow_me: following until cancelled (never lost her)", state_before_cancel == "ACTIVE",
                       f"{state_before_cancel}: {self.s.follow_client.get_goal_status_text()}")
            driving = d[t >= goal_t]
            self.check("follow_me: never nearer than 0.45 m to the user while following",
                       len(driving) > 0 and np.min(driving) >= 0.45,
                       f"least {np.min(driving):.2f} m" if len(driving) else "no samples")
            self.check("follow_me: within 1 m of the asked distance while she walked",
                       measures.get("max_error_m", math.inf) <= 1.0, f"largest error {measures.get('max_error_m')}")
            self.check("follow_me: the right person kept >= 90 % of the walk", measures.get("kept_fraction", 0) >= 0.9,
                       f"{measures.get('kept_fraction')}")
            self.check("follow_me: the robot followed her through the doors (in the bedroom, or its door, at the end)",
                       robot[1] > 6.5, f"robot at ({robot[0]:.2f}, {robot[1]:.2f}), room {self.truth_room()}")

    def _follow_ended(self):
        return self.s.follow_client.get_state() not in (GoalStatus.PENDING, GoalStatus.ACTIVE)

    def approach_user(self):
        p2r = APPROACH["p2r"]
        with self.step("approach_me", f"ApproachMe to {APPROACH['distance']} m beside the seated user "
                       f"(p2r {math.degrees(p2r):.0f} deg, facing her)") as st:
            from approach_me.msg import ApproachMeGoal

            user0, robot0 = self.user(), self.s.robot()
            # where she is, in base_link: the tracker's person nearest to where follow_me last had her
            guess = self.result_xy or (1.0, 0.0)
            odom = self.s.odom_pose()
            near = pose2d.transform_points(odom, [guess])[0]
            tracks = self.s.latest_tracks(filtered=False)
            best = min(tracks.values(), key=lambda xy: math.dist(xy, near), default=None)
            if best is not None and math.dist(best, near) < 0.6:
                guess = tuple(float(v) for v in pose2d.transform_points(pose2d.inverse(odom), [best])[0])
            self.log(f"ApproachMe goal: the user at ({guess[0]:.2f}, {guess[1]:.2f}) in base_link")
            self.s.approach_client.send_goal(ApproachMeGoal(guess[0], guess[1], APPROACH["distance"], p2r,
                                                            APPROACH["r2p"], 0.0, 0.0))
            start = self.s.sim_now()
            wait_for(lambda: self.s.approach_client.get_state() not in (GoalStatus.PENDING, GoalStatus.ACTIVE)
                     or self.s.sim_now() - start > 90.0, self.wall_limit(90.0), what="approach_me's end")
            state = STATE_NAMES.get(self.s.approach_client.get_state())
            text = self.s.approach_client.get_goal_status_text()
            if state in ("PENDING", "ACTIVE"):
                self.s.approach_client.cancel_goal()
                state, text = "TIMEOUT", "no result in 90 simulated s"
            self.s.catch_up()
            self.s.wait_sim(1.0)
            robot, user = self.s.robot(), self.user()
            pos, head = enablers_metrics.approach_errors(robot, user0[:2], robot0[:2], user[:2], APPROACH["distance"],
                                                         p2r, APPROACH["r2p"])
            target = enablers_metrics.approach_target(user0[:2], robot0[:2], APPROACH["distance"], p2r)
            a = locator_metrics.approach(robot, user)
            st.outcome = state
            st.error = (f"{pos:.2f} m from the asked place, heading off {math.degrees(head):.0f} deg; "
                        f"{a.distance:.2f} m from her, at her {a.side_name}")
            st.data.update(position_error_m=round(pos, 3), heading_error_deg=round(math.degrees(head), 1),
                           target=[round(v, 3) for v in target], **a.as_dict())
            self.check("approach_me: SUCCEEDED", state == "SUCCEEDED", f"{state}: {text}")
            self.check(f"approach_me: within {APPROACH_POS_TOL} m of the asked place", pos <= APPROACH_POS_TOL,
                       f"{pos:.3f} m")
            self.check("approach_me: heading within 15 deg of the asked one", head <= APPROACH_HEADING_TOL,
                       f"{math.degrees(head):.1f} deg")
            self.check("approach_me: beside her, not behind", a.side_name in ("left", "right", "front-left",
                                                                            "front-right"), a.side_name)

    def goto_kitchen(self):
        with self.step("gotoRoom", 'gotoRoom("kitchen")') as st:
            self._goto_room("kitchen", st, "gotoRoom")

    def _goto_room(self, room, st, name, sim_timeout=180.0):
        res = self.call("gotoRoom", room)
        for _ in range(10):  # a released manualOverride reaches the locator over a topic: a moment later
            if res.success or "override" not in res.message:
                break
            time.sleep(0.5)
            res = self.call("gotoRoom", room)
        if not res.success:
            st.outcome = "refused"
            self.check(f"{name}: {room} SUCCEEDED", False, res.message)
            return
        done = self.s.wait_status({"SUCCEEDED", "ABORTED", "PREEMPTED", "REJECTED", "RECALLED"}, sim_timeout,
                                  wall_timeout=self.wall_limit(sim_timeout))
        if done.status == "TIMEOUT":
            self.stop_activity()
        self.s.wait_sim(0.5)
        spot = self.call("getHotspot", room)
        here = self.call("getRobotPosRoom")
        x, y, yaw = self.s.robot()
        est = self.call_quiet("getRobotPosXYPhi")
        end = locator_metrics.arrival((x, y), (est.x, est.y), (spot.x, spot.y))
        truth_room = self.truth_room()
        st.outcome = done.status
        st.error = (f"{end.true_distance:.2f} m from the hotspot, heading off "
                    f"{math.degrees(abs(angles.diff(yaw, spot.phi))):.0f} deg")
        st.data.update(error_m=round(end.true_distance, 3), estimate_error_m=round(end.estimated_distance, 3),
                       localization_error_m=round(end.localization_error, 3), truth_room=truth_room,
                       locator_room=here.room)
        self.check(f"{name}: {room} SUCCEEDED", done.status == "SUCCEEDED", f"{done.status}: {done.message}")
        self.check(f"{name}: in the {room} (ground truth), at its hotspot by amcl's estimate "
                   f"(within {locator_metrics.ARRIVAL_TOL:.2f} m) and amcl within "
                   f"{locator_metrics.LOCALIZATION_TOL:.2f} m of the truth",
                   truth_room == room and est.success and end.ok, f"{truth_room}, {end}")
        self.check(f"{name}: getRobotPosRoom says {room}", here.room == room, here.room)

    def hotspot_survives_restart(self):
        label, x, y, phi = NEW_HOTSPOT
        with self.step("setHotspot + restart", f'setHotspot("{label}", {x}, {y}, {phi:.2f}); florence_locator '
                       "killed and started again; getHotspot") as st:
            res = self.call("setHotspot", label, x, y, phi)
            self.check(f'setHotspot("{label}"): accepted', res.success, res.message)
            old = node_pid(self.master.uri, "/florence_locator", caller="/florence_demo")
            if self.meter is not None:
                self.meter.sample()  # its CPU time up to now
            os.kill(old, signal.SIGKILL)
            wait_for(lambda: not pid_alive(old), 30.0, what="florence_locator gone")
            killed = self.s.sim_now()
            self.log(f"florence_locator (pid {old}) killed; starting it again (rosrun, its parameters on the master)")
            proc = rosrun(self.master, "florence_locator", "florence_locator_node", "__name:=florence_locator")
            self.processes.append(proc)

            def up():
                try:
                    return node_pid(self.master.uri, "/florence_locator", caller="/florence_demo") != old
                except Exception:  # noqa: BLE001 - not registered yet
                    return False

            wait_for(lambda: up() or not proc.running(), self.timeout, what="florence_locator registered again")
            if not proc.running():
                raise RuntimeError(f"florence_locator did not start again:\n{proc.output(2000)}")
            wait_for(self._locator_answers, self.timeout, what="the restarted locator's services")
            got = self.call("getHotspot", label)
            with open(self.hotspots_file) as f:
                on_disk = (yaml.safe_load(f) or {}).get("hotspots", {}).get(label)
            back = self.s.sim_now() - killed
            err = math.hypot(got.x - x, got.y - y)
            st.outcome = "served" if got.success else "lost"
            st.error = f"getHotspot off by {err:.4f} m, {abs(angles.diff(got.phi, phi)):.4f} rad; back in {back:.1f} s"
            st.data.update(old_pid=old, restart_s=round(back, 2), on_disk=on_disk)
            self.check("setHotspot + restart: getHotspot serves the new value after the restart",
                       got.success and err < 1e-3 and abs(angles.diff(got.phi, phi)) < 1e-3,
                       f"({got.x:.3f}, {got.y:.3f}, {got.phi:.3f}): {got.message}")
            self.check("setHotspot + restart: the hotspots file holds it", bool(on_disk), f"{on_disk}")

    def stop_activity(self):
        """End a go-to that did not end in time, as a user would: manualOverride on, then off."""
        self.log("stopping the locator's activity (manualOverride true, then false)")
        self.s.set_override(True)
        self.s.wait_sim(1.0)
        self.s.set_override(False)
        self.s.wait_sim(0.5)

    def _locator_answers(self):
        """Whether florenceLocator answers getRobotPosRoom with success (a killed node's services stay
        registered with the master until its successor registers them again: a call may fail)."""
        try:
            return self.s.call("getRobotPosRoom").success
        except (rospy.ServiceException, rospy.ROSException, OSError):
            return False

    def manual_override(self):
        with self.step("manualOverride + teleop", "manualOverride true; go-to refused; keyboard teleop through a "
                       "pseudo-terminal; manualOverride false; gotoRoom(\"kitchen\")") as st:
            self.s.set_override(True)
            self.s.wait_sim(0.5)
            refused = self.call("gotoRoom", "living_room")
            self.check("manualOverride: gotoRoom refused while it is on", not refused.success
                       and "override" in refused.message, refused.message)
            keyboard = PtyKeyboard()
            teleop = ManagedProcess(["rosrun", "turtlebot_teleop", "turtlebot_teleop_key",
                                     "cmd_vel:=/cmd_vel_mux/input/teleop"], env=self.master.env(),
                                    name="turtlebot_teleop_key", stdin=keyboard.slave)
            self.processes.append(teleop)
            try:
                wait_for(lambda: "currently:" in teleop.output() or not teleop.running(), self.timeout,
                         what="the teleop's first screen")
                time.sleep(1.0)  # its publisher connects to the multiplexer
                t0, yaw0 = self.s.sim_now(), self.s.robot()[2]
                self.log("keyboard: holding 'j' (turn left)")
                keyboard.hold("j", 30.0, until=lambda: abs(angles.diff(self.s.robot()[2], yaw0)) > math.radians(60))
                x0, y0, _ = self.s.robot()
                self.log("keyboard: holding 'i' (forward)")
                keyboard.hold("i", 30.0, until=lambda: math.dist(self.s.robot()[:2], (x0, y0)) > 0.3)
                released = self.s.sim_now()
                self.s.wait_sim(3.0)
                track = self.s.track(t0)
                dist, turn = judge.moved(track, t0, self.s.sim_now())
                at_rest = locator_metrics.time_to_stop(track, released)
                keyboard.type("\x03")  # Ctrl-C: the teleop quits
                wait_for(lambda: not teleop.running(), 20.0, what="the teleop to quit")
            finally:
                teleop.stop()
                keyboard.close()
            st.data.update(teleop_moved_m=round(dist, 3), teleop_turned_deg=round(math.degrees(turn), 1),
                           at_rest_after_s=at_rest)
            self.check("teleop: the keys drove the robot (turned > 45 deg, moved > 0.25 m)",
                       abs(turn) > math.radians(45) and dist > 0.25,
                       f"turned {math.degrees(turn):.0f} deg, moved {dist:.2f} m")
            # turtlebot_teleop_key stops ~key_timeout (0.3 s of wall time) after the last key, velocity_filter
            # ramps from 0.3 m/s in 0.3 s; wall time is more simulated time above real time
            self.check("teleop: at rest within 1.5 simulated s of the last key", at_rest is not None and at_rest <= 1.5,
                       f"{at_rest if at_rest is None else round(at_rest, 2)} s")
            self.s.set_override(False)
            self.s.wait_sim(0.5)  # the locator takes the release
            self._goto_room("kitchen", st, "after the override")
            st.outcome = f"teleop moved {dist:.2f} m, turned {math.degrees(turn):.0f} deg; {st.outcome}"

    def tracker_killed(self):
        with self.step("tracker killed", "user_tracker_ni_node killed (SIGKILL); gotoUser; FollowMe") as st:
            from follow_me.msg import FollowMeGoal

            pid = node_pid(self.master.uri, "/user_tracker_ni_node", caller="/florence_demo")
            if self.meter is not None:
                self.meter.sample()
            os.kill(pid, signal.SIGKILL)
            wait_for(lambda: not pid_alive(pid), 30.0, what="user_tracker_ni_node gone")
            self.log(f"user_tracker_ni_node (pid {pid}) killed")
            self.s.wait_sim(2.0)  # longer than follow_me's ~tracker_timeout
            # gotoUser: refused (the tracker's services gone), or, while the master still lists the dead
            # node's services, ended ABORTED by the search that cannot reach the tracker; never hanging
            goto = self.call("gotoUser")
            goto_end = goto.message
            if goto.success:
                done = self.s.wait_status(TERMINAL, 60.0, wall_timeout=self.wall_limit(60.0))
                goto_end = f"{done.status}: {done.message}"
                goto_ok = done.status == "ABORTED"
            else:
                goto_ok = bool(goto.message)
            self.s.follow_client.send_goal(FollowMeGoal(1.0, 0.0, 0.0, 0.0, FOLLOW_DISTANCE))
            start = self.s.sim_now()
            wait_for(lambda: self._follow_ended() or self.s.sim_now() - start > 10.0, self.wall_limit(10.0),
                     what="follow_me's answer without a tracker")
            state = STATE_NAMES.get(self.s.follow_client.get_state())
            text = self.s.follow_client.get_goal_status_text()
            if not self._follow_ended():
                self.s.follow_client.cancel_goal()
            took = self.s.sim_now() - start
            st.outcome = f"gotoUser {'accepted' if goto.success else 'refused'}, {goto_end}; FollowMe {state}"
            st.error = f"FollowMe ended after {took:.1f} simulated s: {text}"
            st.data.update(goto_user=goto_end, follow_me=text, follow_me_s=round(took, 2))
            self.check("tracker killed: gotoUser refused or ABORTED, saying why (no hang)", goto_ok, goto_end)
            self.check("tracker killed: FollowMe ABORTED at once with the reason (no hang)",
                       state == "ABORTED" and took <= 5.0 and bool(text), f"{state} after {took:.1f} s: {text}")

def _short(value):
    return round(value, 3) if isinstance(value, float) and math.isfinite(value) else value
