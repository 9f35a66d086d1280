"""The stop-and-go search of detect_users (seed 3.9), without ROS.

The Kinect tracker gives false detections while the robot moves (seed 3.9.2), so the robot turns
in 45 degree steps and looks only while it stands still, the tracker restarted after each step
(Stop before, Start after: nothing seen while turning survives, seed 3.9.3):

    [look first:  settle, look]                        (the heading it arrived with)
    step k = 1..8: Stop, turn to start + k * 45 deg, Start, settle, look

The first look keeps the tracker's tracks (``reset_first`` false): a person the Kinect saw on the way
in and the laser keeps tracking (the Kinect sees nothing of a standing person's upper body nearer
than about 1.1 m, of a seated one's than about 1.3 m) is found there, where a restarted tracker
would not see them at all. The seed's reason for the restart, OpenNI's ghosts from a moving
Kinect, does not hold for user_tracker_ni, which confirms tracks while the robot moves (follow_me
relies on it); ``reset_first`` true restores the seed's rule.

Headings are absolute (start yaw + k * 45 deg on odometry), so errors of one step do not add up;
after step 8 the robot faces where it started: a full turn. The turns go counter-clockwise; a
turn that ends past its target by up to ``overshoot`` is not turned back (a base that answers late
would overshoot back and forth: in florence_sim on a loaded machine, 670 degrees of turning for a
360 degree search). A look ends the search as soon as a
person is in range; eight looks without one end it ABORTED.

:class:`Search` is stepped by the node at its control rate with the odometry's yaw and yaw rate
and the people seen since the last call; it answers a :class:`Step`: the angular velocity to
command, a tracker service to call (the node calls it and reports back with :meth:`Search.called`)
and, at the end, the outcome.
"""

import math
from dataclasses import dataclass, field

from florence_common import angles

STEP_ANGLE = math.pi / 4  # [rad] 45 degrees, seed 3.9
FOUND, ABORTED = "found", "aborted"


@dataclass(frozen=True)
class SearchParams:
    steps: int = 8  # turns of STEP_ANGLE: 8 make a full turn
    look_first: bool = True  # look at the arrival heading before the first turn ...
    reset_first: bool = False  # ... with the tracker restarted first (false: the tracks it holds count)
    settle_time: float = 0.5  # [s] after Start, before looking (the robot at rest, the tracker confirming)
    look_time: float = 1.0  # [s] a look lasts this long (the tracker reports a person in view within 0.3 s) ...
    look_frames: int = 10  # ... and until the tracker has published this many messages since it looked
    look_timeout: float = 6.0  # [s] ... but no longer (a tracker starved of CPU publishes late)
    max_range: float = 4.0  # [m] a person farther from the robot is not "in range"
    min_clearance: float = 0.15  # [m] a "person" nearer a wall or furniture of the map is the tracker's ghost
    max_speed: float = 0.6  # [rad/s] fastest turn
    min_speed: float = 0.2  # [rad/s] slowest turn command (the base's static friction)
    decel: float = 0.6  # [rad/s^2] braking of the turn profile (below velocity_filter's 1.0)
    tolerance: float = 0.03  # [rad] a heading this near the target is reached
    overshoot: float = 0.2  # [rad] past the target by at most this, the step is done (no turning back)
    lead: float = 0.3  # [s] the braking looks this far ahead at the measured turn rate (late commands)
    still_rate: float = 0.05  # [rad/s] the robot is at rest below this yaw rate
    turn_timeout: float = 10.0  # [s] longest single turn (a blocked base)


def turn_rate(remaining, p):
    """Angular velocity [rad/s] toward a heading ``remaining`` [rad] away (counter-clockwise
    positive): the speed it can still brake from at ``p.decel``, between min_speed and max_speed;
    0 within the tolerance."""
    if abs(remaining) <= p.tolerance:
        return 0.0
    speed = min(p.max_speed, max(p.min_speed, math.sqrt(2.0 * p.decel * abs(remaining))))
    return math.copysign(speed, remaining)


@dataclass(frozen=True)
class Person:
    """A tracked person as the node passes it in: map position [m], distance from the robot [m]."""

    x: float
    y: float
    distance: float
    user_id: int = -1
    clearance: float = math.inf  # [m] to the nearest obstacle of the robot's map (inf: no map)


def pick(people, max_range, min_clearance=0.0):
    """The person the robot approaches: the nearest within ``max_range`` [m] whose centre is at least
    ``min_clearance`` [m] from the map's obstacles (a person's body keeps their centre that far from a
    wall; the tracker's ghosts on door frames and furniture edges are nearer), or None."""
    near = [p for p in people if math.isfinite(p.distance) and p.distance <= max_range
            and math.isfinite(p.x) and math.isfinite(p.y) and p.clearance >= min_clearance]
    return min(near, key=lambda p: p.distance) if near else None


@dataclass
class Step:
    w: float = 0.0  # [rad/s] angular velocity to command (0: stand still)
    call: str = ""  # "stop_tracker" / "start_tracker": call it, then report with Search.called
    outcome: str = ""  # FOUND / ABORTED once the search has ended
    person: Person | None = None
    why: str = ""


@dataclass
class Search:
    """One search from heading ``start_yaw`` [rad] begun at ``now`` [s]."""

    params: SearchParams
    start_yaw: float
    now: float
    step: int = 0  # the step under way: 0 = the first look, 1..steps = turns
    phase: str = "stop_tracker"  # stop_tracker, turn, start_tracker, settle, look, done
    since: float = 0.0  # [s] when the phase began
    waiting: bool = False  # a tracker call is out
    looks: int = 0
    frames: int = 0  # tracker messages of the look under way
    outcome: Step | None = None  # the ending, once phase is "done"
    log: list = field(default_factory=list)

    def __post_init__(self):
        self.since = self.now
        if not self.params.look_first:
            self.step = 1
        elif not self.params.reset_first:
            self.phase = "settle"  # the robot has just stopped; the tracker keeps what it tracks

    @property
    def target(self):
        return angles.wrap(self.start_yaw + self.step * STEP_ANGLE)

    def _enter(self, phase, now):
        self.phase, self.since = phase, now

    def called(self, name, ok, why, now):
        """The tracker service ``name`` answered (ok) or failed (why)."""
        self.waiting = False
        if not ok:
            self._enter("done", now)
            self.outcome = Step(outcome=ABORTED, why=f"user_tracker_ni {name.split('_')[0].capitalize()} failed: {why}")
            return
        if self.phase == "stop_tracker":
            self._enter("turn" if self.step > 0 else "start_tracker", now)
        elif self.phase == "start_tracker":
            self._enter("settle", now)

    def update(self, now, yaw, yaw_rate, people, frames=0):
        """One control cycle: odometry yaw [rad] and yaw rate [rad/s] now, the people seen since
        the last cycle (Person list; only counted while looking) and how many tracker messages
        (``frames``, with people or without) came since the last cycle."""
        if self.phase == "done":
            return self.outcome
        if self.phase in ("stop_tracker", "start_tracker"):
            if self.waiting:
                return Step()
            self.waiting = True
            return Step(call=self.phase)
        if self.phase == "turn":
            return self._turn(now, yaw, yaw_rate)
        if self.phase == "settle":
            if now - self.since >= self.params.settle_time:
                self._enter("look", now)
            return Step()
        if self.phase == "look":
            self.frames += frames
            return self._look(now, people)
        raise AssertionError(f"unknown phase {self.phase}")

    def _turn(self, now, yaw, yaw_rate):
        p = self.params
        remaining = angles.diff(self.target, yaw)
        ahead = remaining - yaw_rate * p.lead  # where the heading will be when a command now takes effect
        w = turn_rate(ahead, p) if ahead * remaining > 0 else 0.0
        if -p.overshoot <= remaining < 0.0:
            # past the target (the base answers late under load): turning back would only overshoot
            # the other way; 45 degree steps under a 57 degree view leave room for it, and the next
            # step's target is absolute, so the error does not add up
            w = 0.0
        if abs(remaining) <= max(p.tolerance, p.overshoot if remaining < 0 else 0.0) and abs(yaw_rate) < p.still_rate:
            self.log.append(f"step {self.step}: at {math.degrees(yaw):.0f} deg")
            self._enter("start_tracker", now)
            return Step()
        if now - self.since > p.turn_timeout:
            return self._end(ABORTED, now, why=f"the turn of step {self.step} did not finish in "
                             f"{p.turn_timeout:.0f} s ({math.degrees(remaining):.0f} deg left): blocked?")
        return Step(w=w)

    def _look(self, now, people):
        p = self.params
        person = pick(people, p.max_range, p.min_clearance)
        if person is not None:
            return self._end(FOUND, now, person=person)
        looked = now - self.since >= p.look_time and self.frames >= p.look_frames
        if looked or now - self.since >= p.look_timeout:
            if not looked:
                self.log.append(f"step {self.step}: the tracker published {self.frames} messages in "
                                f"{p.look_timeout:.0f} s")
            self.looks += 1
            self.frames = 0
            if self.step >= p.steps:
                return self._end(ABORTED, now, why=f"nobody within {p.max_range:.1f} m in {self.looks} looks "
                                 f"over a full turn")
            self.step += 1
            self._enter("stop_tracker", now)
        return Step()

    def _end(self, outcome, now, person=None, why=""):
        self._enter("done", now)
        self.outcome = Step(outcome=outcome, person=person, why=why)
        return self.outcome

    @property
    def tracker_stopped(self):
        """Whether the tracker is (or may be) stopped by this search: Start must follow."""
        return self.phase in ("turn", "start_tracker") or (self.phase == "stop_tracker" and self.waiting)
