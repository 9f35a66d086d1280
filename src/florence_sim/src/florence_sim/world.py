"""World files: Stage-style types composed into a 2.5D world (YAML, no ROS).

A world file (units: metres, radians; colours RGB 0..1)::

    include: [../florence_types.yaml]      # type files, relative to this file
    name: apartment
    ceiling: 2.4                           # [m] ceiling height (0: none)
    map:
      resolution: 0.05                     # [m/cell] of the generated map
      bounds: [[-0.5, -0.5], [8.5, 10.5]]  # [m] map extent; its first corner is the map origin
    walls:                                 # centre lines of walls [m]
      - {type: wall, from: [0, 0], to: [8, 0]}
    objects:                               # furniture: type and pose [x m, y m, yaw rad]
      - {type: dining_table, name: table, pose: [3.0, 3.5, 0.0]}
    rooms:                                 # labelled room polygons [m] and one hotspot [x, y, phi]
      kitchen: {polygon: [[5, 0], [8, 0], [8, 5.5], [5, 5.5]], hotspot: [6.3, 2.5, 0.0]}

A type file defines types once::

    types:
      wall: {thickness: 0.10, height: 2.40, color: [0.9, 0.9, 0.85]}
      dining_table:
        parts:
          - {box: [1.2, 0.8, 0.04], at: [0, 0, 0.71]}     # size x y z [m]; at: bottom centre [m]
          - {cylinder: [0.025, 0.71], at: [0.55, 0.35, 0]}  # radius, height [m]

Every error names the file and the field (``WorldError``).
"""

import math
import os
from dataclasses import dataclass, field

import yaml

from florence_sim.geometry import Box, Cylinder, Scene

ROOMS = ("kitchen", "living_room", "bedroom", "bathroom", "corridor")


class WorldError(ValueError):
    """A world, type or people file is malformed; the message names the file and the field."""

    def __init__(self, path, where, problem):
        super().__init__(f"{path}: {where}: {problem}")
        self.path, self.where, self.problem = path, where, problem


@dataclass
class Room:
    name: str
    polygon: list  # [[x, y], ...] [m]
    hotspot: tuple  # (x [m], y [m], phi [rad])


@dataclass
class World:
    path: str
    name: str
    scene: Scene
    resolution: float  # [m/cell]
    bounds: tuple  # ((x_min, y_min), (x_max, y_max)) [m]
    rooms: dict = field(default_factory=dict)  # name -> Room

    def room_at(self, x, y):
        """Name of the room containing (x, y) [m], or None."""
        for room in self.rooms.values():
            if point_in_polygon(x, y, room.polygon):
                return room.name
        return None


def point_in_polygon(x, y, polygon):
    """Even-odd rule point-in-polygon test."""
    inside = False
    n = len(polygon)
    for i in range(n):
        (x1, y1), (x2, y2) = polygon[i], polygon[(i + 1) % n]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


class _Reader:
    """Typed access to YAML values that reports the file and field of any problem."""

    def __init__(self, path):
        self.path = path

    def fail(self, where, problem):
        raise WorldError(self.path, where, problem)

    def mapping(self, value, where):
        if not isinstance(value, dict):
            self.fail(where, f"expected a mapping, got {type(value).__name__}")
        return value

    def sequence(self, value, where):
        if not isinstance(value, list):
            self.fail(where, f"expected a list, got {type(value).__name__}")
        return value

    def number(self, value, where, minimum=None, positive=False, maximum=None):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(where, f"expected a finite number, got {value!r}")
        if positive and value <= 0:
            self.fail(where, f"must be > 0, got {value!r}")
        if minimum is not None and value < minimum:
            self.fail(where, f"must be >= {minimum}, got {value!r}")
        if maximum is not None and value > maximum:
            self.fail(where, f"must be <= {maximum}, got {value!r}")
        return float(value)

    def vector(self, value, where, length, **kw):
        self.sequence(value, where)
        if len(value) != length:
            self.fail(where, f"expected {length} numbers, got {len(value)}")
        return [self.number(v, f"{where}[{i}]", **kw) for i, v in enumerate(value)]

    def color(self, value, where):
        rgb = self.vector(value, where, 3, minimum=0.0)
        if max(rgb) > 1.0:
            self.fail(where, "colour components must be within 0..1")
        return tuple(rgb)

    def polygon(self, value, where):
        self.sequence(value, where)
        if len(value) < 3:
            self.fail(where, "a polygon needs at least 3 points")
        return [self.vector(p, f"{where}[{i}]", 2) for i, p in enumerate(value)]


def _load_yaml(path, where="file"):
    try:
        with open(path) as f:
            data = yaml.safe_load(f)
    except OSError as exc:
        raise WorldError(path, where, f"cannot read: {exc.strerror}") from exc
    except yaml.YAMLError as exc:
        raise WorldError(path, where, f"not valid YAML: {exc}") from exc
    if not isinstance(data, dict):
        raise WorldError(path, "top level", "expected a mapping")
    return data


def load_types(path):
    """Read a type file: ``{name: definition}`` with each definition validated."""
    data = _load_yaml(path)
    r = _Reader(path)
    types = {}
    for name, spec in r.mapping(data.get("types"), "types").items():
        where = f"types.{name}"
        r.mapping(spec, where)
        color = r.color(spec.get("color", [0.7, 0.7, 0.7]), f"{where}.color")
        if "parts" in spec:
            parts = []
            for i, part in enumerate(r.sequence(spec["parts"], f"{where}.parts")):
                pw = f"{where}.parts[{i}]"
                r.mapping(part, pw)
                at = r.vector(part.get("at", [0, 0, 0]), f"{pw}.at", 3)
                pcolor = r.color(part["color"], f"{pw}.color") if "color" in part else color
                yaw = r.number(part.get("yaw", 0.0), f"{pw}.yaw")
                if "box" in part:
                    size = r.vector(part["box"], f"{pw}.box", 3, positive=True)
                    parts.append(("box", at, size, yaw, pcolor))
                elif "cylinder" in part:
                    size = r.vector(part["cylinder"], f"{pw}.cylinder", 2, positive=True)
                    parts.append(("cylinder", at, size, yaw, pcolor))
                else:
                    r.fail(pw, "a part needs 'box: [sx, sy, sz]' or 'cylinder: [radius, height]'")
            types[name] = {"kind": "object", "parts": parts}
        elif "thickness" in spec:
            types[name] = {
                "kind": "wall",
                "thickness": r.number(spec["thickness"], f"{where}.thickness", positive=True),
                "height": r.number(spec.get("height"), f"{where}.height", positive=True),
                "color": color,
            }
        else:
            r.fail(where, "a type needs 'parts' (furniture) or 'thickness' and 'height' (wall)")
    return types


def instantiate(type_def, name, x, y, yaw):
    """Boxes and cylinders of one object of ``type_def`` at pose (x, y, yaw) [m, m, rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    boxes, cylinders = [], []
    for i, (kind, at, size, part_yaw, color) in enumerate(type_def["parts"]):
        px, py = x + c * at[0] - s * at[1], y + s * at[0] + c * at[1]
        part_name = f"{name}/{i}"
        if kind == "box":
            boxes.append(Box(part_name, px, py, yaw + part_yaw, size[0], size[1], at[2], at[2] + size[2], color))
        else:
            cylinders.append(Cylinder(part_name, px, py, size[0], at[2], at[2] + size[1], color))
    return boxes, cylinders


def wall_box(type_def, name, start, end):
    (x0, y0), (x1, y1) = start, end
    length = math.hypot(x1 - x0, y1 - y0)
    # extend by half the thickness at both ends so that walls meeting at a corner close it
    t = type_def["thickness"]
    return Box(name, (x0 + x1) / 2, (y0 + y1) / 2, math.atan2(y1 - y0, x1 - x0), length + t, t,
               0.0, type_def["height"], type_def["color"])


def load_world(path):
    """Read and validate a world file; returns a :class:`World`."""
    path = os.path.abspath(path)
    data = _load_yaml(path)
    r = _Reader(path)
    base = os.path.dirname(path)
    types = {}
    for i, inc in enumerate(r.sequence(data.get("include", []), "include")):
        if not isinstance(inc, str):
            r.fail(f"include[{i}]", "expected a file name")
        types.update(load_types(os.path.join(base, inc)))

    name = data.get("name", os.path.basename(path))
    ceiling = r.number(data.get("ceiling", 0.0), "ceiling", minimum=0.0)
    m = r.mapping(data.get("map"), "map")
    resolution = r.number(m.get("resolution"), "map.resolution", positive=True)
    bounds = r.sequence(m.get("bounds"), "map.bounds")
    if len(bounds) != 2:
        r.fail("map.bounds", "expected [[x_min, y_min], [x_max, y_max]]")
    lo, hi = r.vector(bounds[0], "map.bounds[0]", 2), r.vector(bounds[1], "map.bounds[1]", 2)
    if hi[0] <= lo[0] or hi[1] <= lo[1]:
        r.fail("map.bounds", "the second corner must be above and right of the first")

    def type_of(item, where, kind):
        tname = item.get("type")
        if tname not in types:
            r.fail(f"{where}.type", f"unknown type {tname!r} (defined: {', '.join(sorted(types)) or 'none'})")
        if types[tname]["kind"] != kind:
            r.fail(f"{where}.type", f"type {tname!r} is not a {kind}")
        return types[tname]

    boxes, cylinders = [], []
    for i, wall in enumerate(r.sequence(data.get("walls", []), "walls")):
        where = f"walls[{i}]"
        r.mapping(wall, where)
        t = type_of(wall, where, "wall")
        start, end = r.vector(wall.get("from"), f"{where}.from", 2), r.vector(wall.get("to"), f"{where}.to", 2)
        if start == end:
            r.fail(where, "a wall needs distinct 'from' and 'to' points")
        boxes.append(wall_box(t, wall.get("name", f"wall_{i}"), start, end))
    names = set()
    for i, obj in enumerate(r.sequence(data.get("objects", []), "objects")):
        where = f"objects[{i}]"
        r.mapping(obj, where)
        t = type_of(obj, where, "object")
        oname = str(obj.get("name", f"{obj['type']}_{i}"))
        if oname in names:
            r.fail(f"{where}.name", f"duplicate object name {oname!r}")
        names.add(oname)
        x, y, yaw = r.vector(obj.get("pose"), f"{where}.pose", 3)
        b, c = instantiate(t, oname, x, y, yaw)
        boxes += b
        cylinders += c
    rooms = {}
    for rname, spec in r.mapping(data.get("rooms", {}) or {}, "rooms").items():
        where = f"rooms.{rname}"
        r.mapping(spec, where)
        poly = r.polygon(spec.get("polygon"), f"{where}.polygon")
        hotspot = tuple(r.vector(spec.get("hotspot"), f"{where}.hotspot", 3))
        if not point_in_polygon(hotspot[0], hotspot[1], poly):
            r.fail(f"{where}.hotspot", f"hotspot {hotspot[:2]} lies outside the room's polygon")
        rooms[rname] = Room(rname, poly, hotspot)
    return World(path, name, Scene(boxes, cylinders, ceiling), resolution, (tuple(lo), tuple(hi)), rooms)
