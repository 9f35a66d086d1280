"""What florenceLocator is doing, without ROS: the go-to activities, gotoUser's phases, the
user's position, manualOverride.

The node feeds events in (calls, move_base's answers, detect_users' and approach_me_map's status,
detections, the clock) and carries out the :class:`Command` list each one returns:

- ``send_goal(x, y, phi)``: a move_base goal for the current activity (its done callback comes
  back as :meth:`Locator.goal_done` with the activity's id);
- ``cancel_goals``: cancel every move_base goal (manualOverride);
- ``cancel_goal``: cancel the locator's own move_base goal;
- ``search(on)``: ``/detect_user/cmd`` true (start the search) or false (stop it);
- ``stop_approach``: ``/detected_user`` with command false (approach_me_map stops).

Status (getStatus) uses actionlib's goal state names for the current or last activity:
PENDING (accepted, move_base has not started it), ACTIVE, SUCCEEDED, ABORTED, PREEMPTED (a new
go-to replaced it, or another move_base client took over), REJECTED / RECALLED (move_base's
answer, relayed), and LOST before any activity (as SimpleActionClient.get_state() without a
goal). gotoUser is ACTIVE through its phases:

1. ``navigate``: to the hotspot of the room where the user was last known (skipped when the
   robot is in that room already, or when the user's room is unknown). A failed leg that still
   ends in the user's room goes on with the search. A leg move_base gave up on while somebody
   stood in its way (move_base's ``~waiting_for``: :meth:`Locator.waiting_for`) sends the robot,
   once per gotoUser, to a place about ``look_reach`` from them with a free line of sight
   (places.FloorMap.lookout), facing them, and the search begins there: who stands still close in
   front of the robot is unknown to the tracker (the Kinect sees no upper body nearer than about
   1.1 m, and the laser confirms walkers), and that may be the user;
2. ``search``: detect_users turns in 45 degree steps (its status ACTIVE, then either a
   ``/detected_user`` or ABORTED after a full turn). A full turn with nobody sends the robot to
   another place in the room to search again (``search_spots`` places in all): the place that
   sees the most of the room's floor the turns so far did not (places.FloorMap.unseen_lookout:
   close to where it turned the Kinect does not see a seated person, and walls, table tops and
   chairs hide others; ``lookout_sight`` the Kinect's reach), else one ``lookout_reach`` from the
   places searched (places.FloorMap.lookout). ``navigate`` and ``search`` then run again;
3. ``approach``: approach_me_map goes to a polite pose near the user (ACTIVE, then SUCCEEDED or
   ABORTED), which ends gotoUser with the same state.

A phase whose node stops sending its status for ``heartbeat_timeout`` [s], or that runs longer
than its timeout, ends gotoUser ABORTED with the reason.
"""

import logging
import math
from dataclasses import dataclass, field

from florence_locator.places import UNKNOWN, Pose, check_label

log = logging.getLogger(__name__)

PENDING, ACTIVE, PREEMPTED, SUCCEEDED, ABORTED, REJECTED, RECALLED, LOST = (
    "PENDING", "ACTIVE", "PREEMPTED", "SUCCEEDED", "ABORTED", "REJECTED", "RECALLED", "LOST")
RUNNING = (PENDING, ACTIVE)
GOTO_ROOM, GOTO_XYPHI, GOTO_USER = "gotoRoom", "gotoXYPhi", "gotoUser"
NAVIGATE, SEARCH, APPROACH = "navigate", "search", "approach"
PHASE_NODE = {SEARCH: "detect_users", APPROACH: "approach_me_map"}
NOBODY = "nobody in a full turn"


@dataclass(frozen=True)
class Command:
    name: str  # send_goal, cancel_goal, cancel_goals, search, stop_approach
    args: tuple = ()
    activity: int = 0  # id of the activity it belongs to


@dataclass(frozen=True)
class Timeouts:
    heartbeat: float = 5.0  # [s] a phase's node silent this long has failed
    search: float = 180.0  # [s] longest search
    approach: float = 240.0  # [s] longest approach


@dataclass
class Activity:
    id: int
    kind: str
    target: str  # what it goes to, in words
    state: str = PENDING
    text: str = ""
    phase: str = ""  # gotoUser only
    room: str = ""  # gotoUser: the room it goes to search in
    started: float = 0.0  # [s]
    phase_started: float = 0.0
    heard: float = 0.0  # [s] the phase's node last sent a status
    notes: list = field(default_factory=list)
    searched: list = field(default_factory=list)  # gotoUser: (x, y) [m] of every full turn with nobody
    leg: str = "the hotspot"  # gotoUser: where the navigate phase drives to, in words
    blocked: tuple | None = None  # gotoUser: (x, y) [m] of whom move_base last waited for on this leg
    looked: bool = False  # gotoUser: the robot went to look at who stood in its way (once)
    sighting: tuple | None = None  # gotoUser: (x, y) [m] of the person seen on the way that began the search

    def describe(self):
        phase = f" [{self.phase}]" if self.phase and self.state in RUNNING else ""
        notes = "".join(f"; {n}" for n in self.notes)
        return f"{self.kind} {self.target}{phase}: {self.text}{notes}"


class Locator:
    """The locator's state. Every method takes the time ``now`` [s] where timing matters and
    returns what the node must do (a list of :class:`Command`); calls also return (ok, message)."""

    def __init__(self, rooms, hotspots, floor=None, timeouts=None, hotspot_clearance=0.15, sighting_margin=0.5,
                 sighting_clearance=0.25, search_spots=1, lookout_reach=2.5, lookout_clearance=0.45, look_reach=2.0,
                 lookout_sight=(1.3, 4.0)):
        self.rooms, self.hotspots = rooms, hotspots
        self.floor = floor  # places.FloorMap, or None until the map comes
        self.occluders = None  # florence_common.grid.Grid of what hides a seated person (the keep-out map), or None
        self.timeouts = timeouts or Timeouts()
        self.hotspot_clearance = hotspot_clearance  # [m] a hotspot must be this far from obstacles
        # [m] a person seen on the way counts this far inside the user's room and from the map's obstacles (the
        # tracker's ghosts sit on door frames and furniture edges: 0.14 m from a door frame in florence_sim)
        self.sighting_margin, self.sighting_clearance = sighting_margin, sighting_clearance
        # gotoUser searches from up to this many places of the user's room (1: the seed's one full turn)
        self.search_spots = max(1, int(search_spots))
        self.lookout_reach, self.lookout_clearance = lookout_reach, lookout_clearance  # places.FloorMap.lookout
        self.lookout_sight = tuple(lookout_sight)  # [m] near, far: where the Kinect sees a seated person
        self.look_reach = look_reach  # [m] from whom stood in the way (0: no look)
        self.user = None  # Pose of the user, None until some sensor says where
        self.user_source = ""
        self.override = False
        self.activity = None
        self.last_goal = None  # Pose of the most recent navigation goal
        self._next_id = 1

    # --- queries ------------------------------------------------------------------------------------------
    def status(self):
        """(state name, text) of the current or last activity."""
        if self.activity is None:
            return LOST, "no activity yet"
        return self.activity.state, self.activity.describe()

    def room_of(self, pose):
        return UNKNOWN if pose is None else self.rooms.room_at(pose.x, pose.y)

    def running(self):
        return self.activity is not None and self.activity.state in RUNNING

    # --- the user -------------------------------------------------------------------------------------------
    def set_user_xyphi(self, pose, source="setUserPosXYPhi"):
        self.user, self.user_source = pose, source
        return True, f"user at ({pose.x:.2f}, {pose.y:.2f}, {pose.phi:.2f}) in {self.room_of(pose)}"

    def set_user_room(self, label):
        """Seed 3.8.1: the user's pose becomes the room's hotspot unless it is in that room already."""
        try:
            name = check_label(label)
        except ValueError as exc:
            return False, str(exc)
        if name not in self.rooms.polygons:
            return False, f"unknown room '{name}' (rooms: {', '.join(self.rooms.labels())})"
        spot = self.hotspots.get(name)
        if spot is None:
            return False, f"room '{name}' has no hotspot to place the user at (setHotspot first)"
        if self.user is not None and self.room_of(self.user) == name:
            return True, f"the user is in {name} already, at ({self.user.x:.2f}, {self.user.y:.2f}): kept"
        self.user, self.user_source = spot, f"setUserPosRoom({name})"
        return True, f"user placed at the hotspot of {name} ({spot.x:.2f}, {spot.y:.2f})"

    def detected(self, x, y, now):
        """detect_users found the user at (x, y) [m, map]: the user's position, and gotoUser's
        search phase gives way to the approach. The heading is kept (the tracker does not say
        which way a person faces)."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return []
        phi = self.user.phi if self.user is not None else 0.0
        self.user, self.user_source = Pose(float(x), float(y), phi), "detect_users"
        a = self.activity
        if a is not None and a.kind == GOTO_USER and a.state in RUNNING and a.phase == SEARCH:
            self._phase(a, APPROACH, now, f"found the user at ({x:.2f}, {y:.2f}); approaching (approach_me_map)")
        return []

    # --- hotspots -------------------------------------------------------------------------------------------
    def check_place(self, pose, what):
        """None, or why the robot cannot go to (or stand at) ``pose`` by the map."""
        if self.floor is None:
            return None
        problem = self.floor.problem(pose.x, pose.y, self.hotspot_clearance)
        return None if problem is None else f"{what}: {problem}"

    # --- go-to calls -------------------------------------------------------------------------------------------
    def _refusal(self):
        if self.override:
            return "manual override is on (/florenceLocator/manualOverride true): no navigation until it is false"
        return None

    def _start(self, kind, target, now, sends_goal):
        """A new activity; the running one (if any) is preempted (its move_base goal cancelled unless
        the new activity sends one, which replaces it). Returns (activity, commands)."""
        commands = []
        old = self.activity
        if old is not None and old.state in RUNNING:
            commands += self._end(old, PREEMPTED, f"replaced by {kind} {target}", cancel_goal=not sends_goal)
        a = Activity(self._next_id, kind, target, started=now, phase_started=now, heard=now)
        self._next_id += 1
        self.activity = a
        return a, commands

    def goto_pose(self, kind, target, pose, now):
        refusal = self._refusal() or self.check_place(pose, f"{kind} {target}")
        if refusal:
            return False, refusal, []
        a, commands = self._start(kind, target, now, sends_goal=True)
        a.text = f"going to ({pose.x:.2f}, {pose.y:.2f}, {pose.phi:.2f})"
        self.last_goal = pose
        return True, f"accepted: {a.text}", [*commands, Command("send_goal", pose.as_tuple(), a.id)]

    def goto_room(self, label, now):
        try:
            name = check_label(label)
        except ValueError as exc:
            return False, f"gotoRoom: {exc}", []
        spot = self.hotspots.get(name)
        if spot is None:
            known = sorted(set(self.hotspots.labels()))
            why = "has no hotspot" if name in self.rooms.polygons else "is not a known room or hotspot"
            return False, f"gotoRoom: '{name}' {why} (hotspots: {', '.join(known)})", []
        return self.goto_pose(GOTO_ROOM, name, spot, now)

    def goto_xyphi(self, pose, now):
        return self.goto_pose(GOTO_XYPHI, f"({pose.x:.2f}, {pose.y:.2f}, {pose.phi:.2f})", pose, now)

    def goto_user(self, robot, now):
        """``robot``: the robot's Pose on the map, or None when tf does not know it."""
        refusal = self._refusal()
        if refusal:
            return False, refusal, []
        user_room = self.room_of(self.user)
        spot = self.hotspots.get(user_room) if user_room != UNKNOWN else None
        if self.user is not None and user_room != UNKNOWN and spot is None:
            return False, f"gotoUser: the user's room '{user_room}' has no hotspot to search from (setHotspot)", []
        robot_room = self.room_of(robot) if robot is not None else None
        navigate = self.user is not None and user_room not in (UNKNOWN, robot_room)
        a, commands = self._start(GOTO_USER, "the user", now, sends_goal=navigate)
        a.room = user_room if user_room != UNKNOWN or robot is None else self.room_of(robot)
        if self.user is None or user_room == UNKNOWN:
            where = "not known" if self.user is None else f"outside every room ({self.user.x:.2f}, {self.user.y:.2f})"
            a.notes.append(f"the user's position is {where}: searching from here")
            commands += self._phase(a, SEARCH, now, "searching for the user here (detect_users)")
        elif not navigate:
            a.notes.append(f"already in {user_room}: no drive to its hotspot")
            commands += self._phase(a, SEARCH, now, f"searching for the user in {user_room} (detect_users)")
        else:
            commands += self._drive(a, spot, now, "the hotspot",
                                    f"going to the hotspot of {user_room}, where the user was last known")
        return True, f"accepted: {a.text}" + "".join(f"; {n}" for n in a.notes), commands

    # --- events -------------------------------------------------------------------------------------------
    def goal_active(self, activity_id):
        a = self.activity
        if a is not None and a.id == activity_id and a.state == PENDING:
            a.state = ACTIVE

    def goal_done(self, activity_id, state, text, robot, now):
        """move_base ended the goal of activity ``activity_id`` in ``state`` (a name) with ``text``."""
        a = self.activity
        if a is None or a.id != activity_id or a.state not in RUNNING:
            return []
        text = text or "no text"
        if a.kind != GOTO_USER:
            if state == SUCCEEDED:
                words = f"arrived (move_base: {text})"
            elif state == PREEMPTED:
                words = f"another move_base client replaced the goal (move_base: {text})"
            else:
                words = f"move_base {state}: {text}"
            return self._end(a, state, words, cancel_goal=False)
        if a.phase != NAVIGATE:
            return []
        place = a.leg
        if state == SUCCEEDED:
            return self._phase(a, SEARCH, now, f"at {place} ({a.room}); searching for the user (detect_users)")
        if robot is not None and self.room_of(robot) == a.room:
            a.notes.append(f"{place} was not reached ({state}: {text}), but the robot is in {a.room}")
            return self._phase(a, SEARCH, now, f"searching for the user in {a.room} (detect_users)")
        look = self._look(a, robot, now, f"{state}: {text}") if state == ABORTED else []
        return look or self._end(a, ABORTED, f"could not reach {a.room} to search for the user: move_base {state}: "
                                 f"{text}", cancel_goal=False)

    def waiting_for(self, x, y):
        """move_base waits for somebody at (x, y) [m, map] in its way (its ``~waiting_for``): kept for
        the leg gotoUser drives (:meth:`_look`, should move_base give up)."""
        a = self.activity
        if a is not None and a.kind == GOTO_USER and a.state in RUNNING and a.phase == NAVIGATE:
            a.blocked = (float(x), float(y))

    def sighted(self, x, y, now):
        """The tracker reports somebody at (x, y) [m, map] near the robot. While gotoUser drives to the
        user's room and the person is in that room, the drive ends here and the search begins: the
        search's first look finds the person the tracker holds, and the robot neither drives up to
        someone standing by the hotspot nor ends too near them for the Kinect to see."""
        a = self.activity
        if (a is None or a.kind != GOTO_USER or a.state not in RUNNING or a.phase != NAVIGATE
                or self.rooms.room_at(x, y) != a.room):
            return []
        if self.floor is not None and (self.floor.problem(x, y, self.sighting_clearance) is not None
                                       or self.floor.depth_inside(self.rooms.polygons[a.room], x, y)
                                       < self.sighting_margin):
            return []
        a.sighting = (float(x), float(y))
        a.notes.append(f"saw somebody at ({x:.2f}, {y:.2f}) in {a.room} on the way: searching from there")
        return [Command("cancel_goal", (), a.id), *self._phase(a, SEARCH, now, f"searching for the user in {a.room} "
                                                               "(detect_users)")]

    def phase_status(self, status, now, robot=None):
        """A message on /approach_user/status (detect_users' or approach_me_map's). ``robot``: the
        robot's Pose on the map (where a search that ends ABORTED turned), or None."""
        a = self.activity
        if a is None or a.kind != GOTO_USER or a.state not in RUNNING or a.phase not in (SEARCH, APPROACH):
            return []
        status = status.strip().upper()
        if status == ACTIVE:
            a.heard = now
            return []
        if a.phase == SEARCH and status == ABORTED:
            return self._search_again(a, robot, now)
        if a.phase == APPROACH and status == SUCCEEDED:
            u = self.user
            return self._end(a, SUCCEEDED, f"beside the user at ({u.x:.2f}, {u.y:.2f}) (approach_me_map)")
        if a.phase == APPROACH and status == ABORTED:
            u = self.user
            return self._end(a, ABORTED, f"approach_me_map could not reach a polite pose near the user at "
                             f"({u.x:.2f}, {u.y:.2f})")
        return []  # PREEMPTED and the like: answers to our own cancels

    def set_override(self, on, now):
        """manualOverride: true aborts whatever runs (every move_base goal, the search, the approach)."""
        self.override = bool(on)
        if not on:
            return []
        commands = [Command("cancel_goals"), Command("search", (False,)), Command("stop_approach")]
        a = self.activity
        if a is not None and a.state in RUNNING:
            self._end(a, ABORTED, "manual override (/florenceLocator/manualOverride true)", cancel_goal=False)
        return commands

    def tick(self, now):
        """Timeouts of gotoUser's search and approach phases."""
        a = self.activity
        if a is None or a.kind != GOTO_USER or a.state not in RUNNING or a.phase not in (SEARCH, APPROACH):
            return []
        node = PHASE_NODE[a.phase]
        if now - a.heard > self.timeouts.heartbeat:
            return self._end(a, ABORTED, f"{node} sent no status for {now - a.heard:.1f} s: is it running?")
        limit = self.timeouts.search if a.phase == SEARCH else self.timeouts.approach
        if now - a.phase_started > limit:
            return self._end(a, ABORTED, f"the {a.phase} phase ({node}) took longer than {limit:.0f} s")
        return []

    def cancel(self, reason, now):
        """End the running activity ABORTED (a node shutting down)."""
        a = self.activity
        if a is None or a.state not in RUNNING:
            return []
        return self._end(a, ABORTED, reason)

    # --- helpers -------------------------------------------------------------------------------------------
    def _search_again(self, a, robot, now):
        """detect_users turned a full circle at ``robot`` and found nobody: the drive to the next place
        to search the room from, or the end. After a person seen on the way (``a.sighting``), the next
        place is chosen from where they were (about lookout_reach from it, seeing it, facing it), not
        from the places searched: the search that began where the robot stopped may have been too
        near a seated person for the Kinect (about 1.3 m; the tracker restarted for each step forgets
        her), and in a small room a place far from that one can be as near her. Otherwise the place
        that sees most of what the turns so far did not (FloorMap.unseen_lookout, ``occluders`` hiding
        too), else one lookout_reach from the places searched (FloorMap.lookout)."""
        if robot is not None:
            a.searched.append((robot.x, robot.y))
        where = " and ".join(f"({x:.2f}, {y:.2f})" for x, y in a.searched) or "here"
        spot = None
        if len(a.searched) < self.search_spots and self.floor is not None and a.room in self.rooms.polygons:
            polygon = self.rooms.polygons[a.room]
            if a.sighting is not None:
                spot = self.floor.lookout(polygon, [a.sighting], self.lookout_reach, self.lookout_clearance,
                                          need_sight=True)
            if spot is None:
                near, far = self.lookout_sight
                spot = self.floor.unseen_lookout(polygon, a.searched, near, far, self.lookout_clearance,
                                                 occluders=self.occluders)
            if spot is None:
                spot = self.floor.lookout(polygon, a.searched, self.lookout_reach, self.lookout_clearance)
        a.notes = [n for n in a.notes if not n.startswith(NOBODY)]  # the text names every place
        if spot is None:
            return self._end(a, ABORTED, f"detect_users found {NOBODY} at {where} (or could not use the tracker; "
                             "see its log)")
        a.notes.append(f"{NOBODY} at {where}")
        return self._drive(a, spot, now, "the next place to search",
                           f"going to ({spot.x:.2f}, {spot.y:.2f}) in {a.room} to search again")

    def _look(self, a, robot, now, why):
        """move_base gave up the leg (``why``) while somebody stood in its way at ``a.blocked``: the drive
        to a place of the robot's room about look_reach from them that sees them along a free line,
        facing them, where the search begins (once per gotoUser); [] when there is none."""
        if a.looked or a.blocked is None or robot is None or self.floor is None or self.look_reach <= 0.0:
            return []
        polygon = self.rooms.polygons.get(self.room_of(robot))
        if polygon is None:
            return []
        spot = self.floor.lookout(polygon, [a.blocked], self.look_reach, self.lookout_clearance, need_sight=True)
        if spot is None:
            return []
        bx, by = a.blocked
        a.looked = True
        a.notes.append(f"move_base gave up while somebody stood in its way at ({bx:.2f}, {by:.2f}) ({why}): "
                       f"looking at them from ({spot.x:.2f}, {spot.y:.2f})")
        return self._drive(a, spot, now, "the place to see who stood in the way", f"going to ({spot.x:.2f}, "
                           f"{spot.y:.2f}) to see who stands in the way at ({bx:.2f}, {by:.2f})")

    def _drive(self, a, spot, now, leg, text):
        """gotoUser's navigate phase to ``spot`` (a Pose), ``leg`` naming it."""
        a.phase, a.phase_started, a.leg, a.blocked, a.text = NAVIGATE, now, leg, None, text
        self.last_goal = spot
        return [Command("send_goal", spot.as_tuple(), a.id)]

    def _phase(self, a, phase, now, text):
        a.phase, a.phase_started, a.heard, a.state, a.text = phase, now, now, ACTIVE, text
        return [Command("search", (True,), a.id)] if phase == SEARCH else []

    def _end(self, a, state, text, cancel_goal=True):
        a.state, a.text = state, text
        log.info("%s", a.describe())
        commands = []
        if a.kind == GOTO_USER and state != SUCCEEDED:
            if a.phase == SEARCH:
                commands.append(Command("search", (False,), a.id))
            if a.phase == APPROACH:
                commands.append(Command("stop_approach", (), a.id))
        if cancel_goal and a.phase in ("", NAVIGATE) and state != SUCCEEDED:
            commands.append(Command("cancel_goal", (), a.id))
        return commands
