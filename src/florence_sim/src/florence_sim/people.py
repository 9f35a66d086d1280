"""Simulated people: legs at laser height, torso and head up to their height (no ROS).

A person stands, sits, or walks along waypoints at a set speed (modes ``loop``,
``back_and_forth``, ``once``), pausing at each waypoint, and waits while the robot
stands in the way (turning back after :data:`PATIENCE` seconds). The body is made of
cylinders, so the laser sees two legs and the Kinect the shirt colour. Paths
are checked against the world: one through a wall or furniture is refused.

People differ in ``height`` [m] (standing height, 1.40..2.05, default 1.72) and ``build``
(dimensionless, 0.75..1.35, default 1): every height of the body (a seated person's too), the
forward reach (leg swing, stride, a seated person's thighs) scale with height / 1.72, every
radius and sideways offset (hip width) with build. The defaults give the body of
:data:`STANDING` and :data:`SITTING` exactly.
"""

import difflib
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from florence_sim.geometry import Cylinder
from florence_sim.world import WorldError, _load_yaml, _Reader

MODES = ("loop", "back_and_forth", "once")
POSTURES = ("standing", "sitting")
RADIUS = 0.20  # [m] footprint radius used for path checks and collisions (a wider torso: its radius)
HEIGHT = 1.72  # [m] default standing height; the body tables below are for this height
HEIGHT_RANGE = (1.40, 2.05)  # [m] allowed standing heights (people files, ~set_person)
BUILD_RANGE = (0.75, 1.35)  # allowed builds: scale of every body radius and width
SKIN = (0.87, 0.72, 0.60)
TROUSERS = (0.20, 0.20, 0.25)
STRIDE = 1.2  # [m] distance for one full leg cycle (at the default height)
SWING = 0.12  # [m] forward/backward leg swing amplitude while walking (at the default height)
GAP = 0.15  # [m] a walking person keeps this gap to the robot (and waits if it is in the way)
# A person waits for the robot only when their step heads at it: within this angle [rad] of the
# line to the robot's centre. One who passes beside it (or whose next waypoint lies a centimetre
# beyond their last step) walks on, as anyone would; head-on in a corridor they wait.
WAIT_CONE = math.radians(60.0)
# A walking person who has waited this long [s] for the robot turns back and walks their route the
# other way (modes loop and back_and_forth; one walking ``once`` waits on): nobody stands for ever
# half a metre from a robot that does not move, and a robot and a person waiting for each other in
# a corridor would otherwise both wait until the robot gives up.
PATIENCE = 10.0
# Whichever way they head, nobody walks into the robot: a step that would bring a person within
# this gap [m] of its body (radius + theirs + TOUCH_GAP between centres), nearer than before,
# waits too. Without it a person passing beside the robot (outside WAIT_CONE) walked on into its
# side, and a robot moving out of their way was counted a collision it could not avoid.
TOUCH_GAP = 0.05
# Body parts of a person HEIGHT tall of build 1, in the person's frame (x forward, y left, z up):
# name, x [m], y [m], radius [m], bottom z [m], top z [m], colour (None: the shirt's), swing sign
# (a walking person's legs swing forward by +-SWING * sin(phase)).
STANDING = (("leg_l", 0.0, 0.10, 0.065, 0.0, 0.85, TROUSERS, 1), ("leg_r", 0.0, -0.10, 0.065, 0.0, 0.85, TROUSERS, -1),
            ("torso", 0.0, 0.0, 0.18, 0.85, 1.48, None, 0), ("head", 0.0, 0.0, 0.10, 1.50, HEIGHT, SKIN, 0))
# thighs forward, torso and head lower
SITTING = (("legs", 0.15, 0.0, 0.15, 0.0, 0.50, TROUSERS, 0), ("torso", 0.0, 0.0, 0.17, 0.50, 1.05, None, 0),
           ("head", 0.0, 0.0, 0.10, 1.10, 1.32, SKIN, 0))
BODIES = {"standing": STANDING, "sitting": SITTING}
TORSO_RADIUS = 0.18  # [m] the standing torso's radius at build 1: the widest part of the body
# keys of a person in a people file or a ~set_person spec
SPEC_KEYS = ("id", "shirt", "posture", "path", "pose", "speed", "pause", "mode", "height", "build")


@dataclass
class Person:
    """One person. Pose (x, y, yaw) [m, m, rad]; ``path`` [(x, y), ...] [m]; speed [m/s]."""

    id: str
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    shirt: tuple = (0.8, 0.1, 0.1)
    posture: str = "standing"
    path: list = field(default_factory=list)
    speed: float = 0.5
    mode: str = "loop"
    pause: float = 0.0  # [s] standing still at each waypoint
    height: float = HEIGHT  # [m] standing height (a seated person is scaled by height / HEIGHT too)
    build: float = 1.0  # scale of every body radius and width
    # walking state
    target: int = 1
    direction: int = 1
    wait: float = 0.0
    phase: float = 0.0  # [rad] leg swing phase
    vx: float = 0.0
    vy: float = 0.0
    finished: bool = False
    blocked: float = 0.0  # [s] waited for the robot since the last step taken

    def __post_init__(self):
        if self.path:
            self.x, self.y = self.path[0]
            if len(self.path) > 1:
                (x0, y0), (x1, y1) = self.path[0], self.path[1]
                self.yaw = math.atan2(y1 - y0, x1 - x0)

    @property
    def radius(self):
        """Footprint radius [m] for path checks and keeping clear of the robot: RADIUS, or the
        torso's radius when it is wider (build above 1.11)."""
        return max(RADIUS, TORSO_RADIUS * self.build)

    @property
    def walking(self):
        return len(self.path) > 1 and not self.finished

    def step(self, dt, keep_clear=None):
        """Advance the walk by ``dt`` [s]. ``keep_clear`` = (x, y, radius) [m] of something
        (the robot) the person does not walk into: they wait while it is in the way (their step
        would bring them within its radius + theirs + GAP, heading at it: :data:`WAIT_CONE`; or
        within :data:`TOUCH_GAP` of it, whichever way), and turn back after :data:`PATIENCE`."""
        self.vx = self.vy = 0.0
        if not self.walking:
            return
        if keep_clear is not None:
            saved = (self.x, self.y, self.yaw, self.target, self.direction, self.wait, self.phase, self.finished)
            before = math.hypot(self.x - keep_clear[0], self.y - keep_clear[1])
            self.step(dt)
            after = math.hypot(self.x - keep_clear[0], self.y - keep_clear[1])
            step_x, step_y = self.x - saved[0], self.y - saved[1]
            to_x, to_y = keep_clear[0] - saved[0], keep_clear[1] - saved[1]
            heads_at = step_x * to_x + step_y * to_y > math.cos(WAIT_CONE) * math.hypot(step_x, step_y) * before
            touches = after < keep_clear[2] + self.radius + TOUCH_GAP
            if after < before and (touches or (after < keep_clear[2] + self.radius + GAP and heads_at)):
                (self.x, self.y, self.yaw, self.target, self.direction, self.wait, self.phase,
                 self.finished) = saved
                self.vx = self.vy = 0.0
                self.blocked += dt
                if self.blocked >= PATIENCE and self.mode != "once":
                    self.turn_back()
            else:
                self.blocked = 0.0
            return
        if self.wait > 0:
            self.wait = max(0.0, self.wait - dt)
            return
        remaining = self.speed * dt
        while remaining > 1e-12 and not self.finished:
            tx, ty = self.path[self.target]
            dx, dy = tx - self.x, ty - self.y
            dist = math.hypot(dx, dy)
            if dist > 1e-9:
                self.yaw = math.atan2(dy, dx)
            move = min(dist, remaining)
            if dist > 1e-9:
                self.x += dx / dist * move
                self.y += dy / dist * move
            remaining -= move
            self.phase += 2 * math.pi * move / (STRIDE * (self.height / HEIGHT))
            if move >= dist - 1e-12:
                self._next_waypoint()
                if self.pause > 0:
                    self.wait = self.pause
                    break
        self.vx = self.speed * math.cos(self.yaw) if not self.finished else 0.0
        self.vy = self.speed * math.sin(self.yaw) if not self.finished else 0.0

    def turn_back(self):
        """Walk the route the other way from here: toward the waypoint last passed, then on in the
        reverse order (a loop backwards; back and forth from the other end)."""
        n = len(self.path)
        came_from = self.target - self.direction
        self.target = came_from % n if self.mode == "loop" else min(max(came_from, 0), n - 1)
        self.direction = -self.direction
        self.wait = 0.0
        self.blocked = 0.0

    def _next_waypoint(self):
        n = len(self.path)
        nxt = self.target + self.direction
        if 0 <= nxt < n:
            self.target = nxt
        elif self.mode == "loop":
            self.target = 0 if nxt >= n else n - 1
        elif self.mode == "back_and_forth":
            self.direction = -self.direction
            self.target += self.direction
        else:
            self.finished = True

    def primitives(self):
        """Cylinders of the body at the current pose: :data:`BODIES` scaled by height and build."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        tall, wide = self.height / HEIGHT, self.build  # exactly 1.0 for the defaults
        swing = SWING * tall * math.sin(self.phase) if self.walking else 0.0
        out = []
        for name, fx, fy, r, z0, z1, color, sign in BODIES[self.posture]:
            ax, ay = fx * tall + sign * swing, fy * wide  # [m] forward, left of the person
            out.append(Cylinder(f"person/{self.id}/{name}", self.x + c * ax - s * ay, self.y + s * ax + c * ay,
                                r * wide, z0 * tall, z1 * tall, self.shirt if color is None else color))
        return out


def check_path(person, scene, source="people"):
    """Raise :class:`WorldError` if the person's path or pose hits an obstacle of ``scene``."""
    points = [tuple(p) for p in person.path] or [(person.x, person.y)]
    segments = list(itertools.pairwise(points))
    if person.mode == "loop" and len(points) > 2:
        segments.append((points[-1], points[0]))
    if not segments:
        segments = [(points[0], points[0])]
    for i, ((x0, y0), (x1, y1)) in enumerate(segments):
        n = max(2, int(math.hypot(x1 - x0, y1 - y0) / 0.05) + 1)
        xs, ys = np.linspace(x0, x1, n), np.linspace(y0, y1, n)
        dist, owner = scene.clearance(np.stack([xs, ys], axis=1), z_max=person.height)
        bad = np.nonzero(dist < person.radius)[0]
        if len(bad):
            k = bad[0]
            what = scene.names[owner[k]]
            where = f"person {person.id}: path segment {i} ({x0:g}, {y0:g}) -> ({x1:g}, {y1:g})" if person.path \
                else f"person {person.id}: pose ({x0:g}, {y0:g})"
            raise WorldError(source, where, f"passes through {what!r} at ({xs[k]:.2f}, {ys[k]:.2f}) "
                                            f"(this person needs {person.radius:.3g} m of clearance)")


def person_from_spec(spec, r, where):
    """Build a :class:`Person` from a people-file entry (validated through reader ``r``)."""
    r.mapping(spec, where)
    for key in spec:
        if key not in SPEC_KEYS:
            close = difflib.get_close_matches(str(key), SPEC_KEYS, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            r.fail(f"{where}.{key}", f"unknown key {key!r}{hint}; a person takes {', '.join(SPEC_KEYS)}")
    pid = spec.get("id")
    if not isinstance(pid, str) or not pid:
        r.fail(f"{where}.id", "every person needs a non-empty string id")
    kwargs = {"id": pid}
    if "shirt" in spec:
        kwargs["shirt"] = r.color(spec["shirt"], f"{where}.shirt")
    posture = spec.get("posture", "standing")
    if posture not in POSTURES:
        r.fail(f"{where}.posture", f"must be one of {', '.join(POSTURES)}, got {posture!r}")
    kwargs["posture"] = posture
    if "path" in spec:
        path = r.sequence(spec["path"], f"{where}.path")
        if not path:
            r.fail(f"{where}.path", "a path needs at least one waypoint")
        kwargs["path"] = [tuple(r.vector(p, f"{where}.path[{i}]", 2)) for i, p in enumerate(path)]
        if posture == "sitting" and len(path) > 1:
            r.fail(f"{where}.posture", "a sitting person cannot walk a path")
    elif "pose" in spec:
        kwargs["x"], kwargs["y"], kwargs["yaw"] = r.vector(spec["pose"], f"{where}.pose", 3)
    else:
        r.fail(where, "a person needs 'pose: [x, y, yaw]' or 'path: [[x, y], ...]'")
    kwargs["speed"] = r.number(spec.get("speed", 0.5), f"{where}.speed", positive=True)
    kwargs["pause"] = r.number(spec.get("pause", 0.0), f"{where}.pause", minimum=0.0)
    mode = spec.get("mode", "loop")
    if mode not in MODES:
        r.fail(f"{where}.mode", f"must be one of {', '.join(MODES)}, got {mode!r}")
    kwargs["mode"] = mode
    for key, default, (lo, hi) in (("height", HEIGHT, HEIGHT_RANGE), ("build", 1.0, BUILD_RANGE)):
        kwargs[key] = r.number(spec.get(key, default), f"{where}.{key}", minimum=lo, maximum=hi)
    return Person(**kwargs)


def load_people(path, scene):
    """Read a people file; every path is checked against ``scene`` (walls and furniture)."""
    data = _load_yaml(path)
    r = _Reader(path)
    people = []
    ids = set()
    for i, spec in enumerate(r.sequence(data.get("people", []), "people")):
        person = person_from_spec(spec, r, f"people[{i}]")
        if person.id in ids:
            r.fail(f"people[{i}].id", f"duplicate id {person.id!r}")
        ids.add(person.id)
        check_path(person, scene, source=path)
        people.append(person)
    return people
