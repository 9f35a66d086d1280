"""Rooms and hotspots of florenceLocator (seed 3.8), without ROS.

Rooms are labelled polygons of the map (x [m], y [m] in the map frame); :meth:`Rooms.room_at`
maps any point to the label of the room that holds it, or :data:`UNKNOWN` outside every room.
A point on an edge belongs to the room: where rooms share an edge (the apartment's polygons meet
at the wall centre lines), it belongs to the first of them in the file's order.

Hotspots are labelled poses (x [m], y [m], phi [rad], map frame): one per room, the goal of
gotoRoom, and any other place worth a name (a TV, the blood pressure monitor). :class:`Hotspots`
loads them from YAML and saves them with florence_common.files.atomic_write (a temporary file,
fsync, rename): a process killed in the middle of a save leaves the old file or the new one.

Files (a bad file is a :class:`florence_common.yamlfile.YamlError` naming the file and line):

    rooms:                                   # either form per room
      kitchen: [[5.0, 0.0], [8.0, 0.0], [8.0, 5.5], [5.0, 5.5]]
      bedroom: {polygon: [[0, 6.8], ...], hotspot: {x: 1.2, y: 7.6, phi: 1.57}}
    hotspots:
      kitchen: {x: 6.3, y: 2.5, phi: 0.0}
"""

import math
import threading
from dataclasses import dataclass

import numpy as np
import yaml

from florence_common import angles
from florence_common.files import atomic_write
from florence_common.grid import Grid
from florence_common.yamlfile import YamlError, line_of, load

UNKNOWN = "unknown"  # the label of every point outside the rooms (never a room's name)
EDGE_TOLERANCE = 1e-6  # [m] a point this near an edge lies on it
MAX_LOOKOUT_CELLS = 2000  # FloorMap.unseen_lookout's grid over a room's bounding box at most (0.2 m up to 80 m^2)


def check_label(label):
    """The label stripped, or ValueError saying why it cannot name a place."""
    if not isinstance(label, str):
        raise ValueError(f"a label must be text, got {label!r}")
    name = label.strip()
    if not name:
        raise ValueError("the label is empty")
    if name == UNKNOWN:
        raise ValueError(f"'{UNKNOWN}' is the label of places outside every room, not a place")
    if any(ord(c) < 32 for c in name):
        raise ValueError(f"the label {label!r} holds control characters")
    return name


def _number(value, path, line, what):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise YamlError(path, line, f"{what} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise YamlError(path, line, f"{what} must be finite, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Pose:
    """A labelled place or the user's pose: x [m], y [m], phi [rad] in the map frame."""

    x: float
    y: float
    phi: float

    def as_tuple(self):
        return self.x, self.y, self.phi


def check_pose(x, y, phi):
    """Pose(x, y, wrapped phi) or ValueError for NaN or infinite values."""
    bad = [n for n, v in (("x", x), ("y", y), ("phi", phi)) if not math.isfinite(v)]
    if bad:
        raise ValueError(f"{', '.join(bad)} must be finite numbers, got x={x}, y={y}, phi={phi}")
    return Pose(float(x), float(y), float(angles.wrap(float(phi))))


# --- rooms --------------------------------------------------------------------------------------------
def _on_segment(px, py, ax, ay, bx, by):
    cross = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    length = math.hypot(bx - ax, by - ay)
    if abs(cross) > EDGE_TOLERANCE * max(length, 1e-12):
        return False
    return (min(ax, bx) - EDGE_TOLERANCE <= px <= max(ax, bx) + EDGE_TOLERANCE
            and min(ay, by) - EDGE_TOLERANCE <= py <= max(ay, by) + EDGE_TOLERANCE)


def contains(polygon, x, y):
    """Whether the closed polygon [[x, y], ...] holds (x, y): inside, or on an edge or corner.
    Even-odd rule (crossings of a ray to +x), so any simple polygon works, concave ones too."""
    pts = np.asarray(polygon, dtype=float)
    n = len(pts)
    inside = False
    for i in range(n):
        ax, ay = pts[i]
        bx, by = pts[(i + 1) % n]
        if _on_segment(x, y, ax, ay, bx, by):
            return True
        if (ay > y) != (by > y):
            cross_x = ax + (y - ay) * (bx - ax) / (by - ay)
            if x < cross_x:
                inside = not inside
    return inside


def contains_points(polygon, points):
    """:func:`contains` for many points: bool [N] for points [N, 2] (numpy, edge by edge)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    poly = np.asarray(polygon, dtype=float)
    x, y = pts[:, 0], pts[:, 1]
    inside = np.zeros(len(pts), dtype=bool)
    on_edge = np.zeros(len(pts), dtype=bool)
    for (ax, ay), (bx, by) in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        cross = (bx - ax) * (y - ay) - (by - ay) * (x - ax)
        length = max(math.hypot(bx - ax, by - ay), 1e-12)
        on_edge |= ((np.abs(cross) <= EDGE_TOLERANCE * length)
                    & (x >= min(ax, bx) - EDGE_TOLERANCE) & (x <= max(ax, bx) + EDGE_TOLERANCE)
                    & (y >= min(ay, by) - EDGE_TOLERANCE) & (y <= max(ay, by) + EDGE_TOLERANCE))
        if ay != by:
            straddles = (ay > y) != (by > y)
            cross_x = ax + (y - ay) * (bx - ax) / (by - ay)
            inside ^= straddles & (x < cross_x)
    return inside | on_edge


class Rooms:
    """Labelled polygons, in the file's order (which decides shared edges)."""

    def __init__(self, polygons, path="<rooms>"):
        self.path = path
        self.polygons = {}  # label -> (N, 2) array [m]
        self.hotspots = {}  # label -> Pose, for rooms whose entry has one (maps/<map>/rooms.yaml)
        for label, polygon in polygons.items():
            self.polygons[check_label(label)] = np.asarray(polygon, dtype=float).reshape(-1, 2)

    @classmethod
    def load(cls, path):
        """Rooms of a rooms file; YamlError naming the file and line of the first problem."""
        data = load(path)
        if not isinstance(data, dict) or not isinstance(data.get("rooms"), dict) or not data["rooms"]:
            raise YamlError(path, line_of(data, "rooms") if isinstance(data, dict) else 1,
                            "expected a mapping 'rooms' of room labels to polygons [[x, y], ...]")
        rooms = data["rooms"]
        polygons, hotspots = {}, {}
        for label, entry in rooms.items():
            line = line_of(rooms, label)
            try:
                name = check_label(label)
            except ValueError as exc:
                raise YamlError(path, line, str(exc)) from None
            polygon = entry
            if isinstance(entry, dict):
                unknown_keys = sorted(set(entry) - {"polygon", "hotspot"})
                if unknown_keys:
                    raise YamlError(path, line_of(entry, unknown_keys[0]),
                                    f"room '{name}': unknown key {unknown_keys[0]!r} (polygon, hotspot)")
                if "hotspot" in entry:
                    hotspots[name] = _pose_entry(entry["hotspot"], path, line_of(entry, "hotspot"), name)
                polygon = entry.get("polygon")
                line = line_of(entry, "polygon") if "polygon" in entry else line
            polygons[name] = _polygon(polygon, path, line, name)
        out = cls(polygons, str(path))
        out.hotspots = hotspots
        return out

    def labels(self):
        return list(self.polygons)

    def rooms_at(self, points):
        """Labels (object array [N]) of the rooms holding points [N, 2], as :meth:`room_at` would."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        out = np.full(len(pts), UNKNOWN, dtype=object)
        todo = np.all(np.isfinite(pts), axis=1)
        for label, polygon in self.polygons.items():
            hit = todo & contains_points(polygon, pts)
            out[hit] = label
            todo &= ~hit
        return out

    def room_at(self, x, y):
        """Label of the room holding (x [m], y [m]), the first in file order on a shared edge;
        UNKNOWN outside every room or for a point that is not finite."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return UNKNOWN
        for label, polygon in self.polygons.items():
            if contains(polygon, x, y):
                return label
        return UNKNOWN


def _polygon(value, path, line, name):
    if not isinstance(value, list) or len(value) < 3:
        raise YamlError(path, line, f"room '{name}': a polygon needs at least 3 points [[x, y], ...], got {value!r}")
    points = []
    for i, point in enumerate(value):
        where = line_of(value, i) or line
        if not isinstance(point, list) or len(point) != 2:
            raise YamlError(path, where, f"room '{name}': point {i} must be [x, y], got {point!r}")
        points.append([_number(v, path, where, f"room '{name}': point {i}") for v in point])
    pts = np.asarray(points)
    area = 0.5 * float(np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1]))
    if abs(area) < 1e-6:
        raise YamlError(path, line, f"room '{name}': the polygon has no area")
    return points


def _pose_entry(entry, path, line, name):
    if not isinstance(entry, dict):
        raise YamlError(path, line, f"'{name}': expected {{x: .., y: .., phi: ..}}, got {entry!r}")
    missing = [k for k in ("x", "y", "phi") if k not in entry]
    extra = sorted(set(entry) - {"x", "y", "phi"})
    if missing or extra:
        problem = f"missing {', '.join(missing)}" if missing else f"unknown key {extra[0]!r}"
        raise YamlError(path, line, f"'{name}': {problem} (x [m], y [m], phi [rad])")
    values = [_number(entry[k], path, line_of(entry, k) or line, f"'{name}'.{k}") for k in ("x", "y", "phi")]
    return Pose(values[0], values[1], float(angles.wrap(values[2])))


# --- the map -------------------------------------------------------------------------------------------------
class FloorMap(Grid):
    """The robot's map (florence_common.grid.Grid) saying whether the robot can stand at a point."""

    def problem(self, x, y, clearance=0.0):
        """None when the robot can stand at (x, y) [m] with ``clearance`` [m] to every obstacle or
        unknown cell, else the reason in words."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return "the point is not finite"
        rows, cols, inside = self.cells([[x, y]])
        if not inside[0]:
            return f"({x:.2f}, {y:.2f}) is off the map"
        value = int(self.data[rows[0], cols[0]])
        if value < 0:
            return f"({x:.2f}, {y:.2f}) is unknown space on the map"
        if value >= self.occupied:
            return f"({x:.2f}, {y:.2f}) is inside a wall or furniture on the map"
        if clearance > 0 and self.clearance_at([[x, y]])[0] < clearance:
            return f"({x:.2f}, {y:.2f}) is less than {clearance:.2f} m from an obstacle on the map"
        return None

    def depth_inside(self, polygon, x, y):
        """[m] from (x, y) to the nearest edge of ``polygon`` (0 outside it)."""
        if not contains(polygon, x, y):
            return 0.0
        pts = np.asarray(polygon, dtype=float)
        best = math.inf
        for (ax, ay), (bx, by) in zip(pts, np.roll(pts, -1, axis=0), strict=True):
            dx, dy = bx - ax, by - ay
            t = 0.0 if dx == dy == 0 else max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)))
            best = min(best, math.hypot(x - ax - t * dx, y - ay - t * dy))
        return best

    def lookout(self, polygon, searched, reach=2.5, clearance=0.45, step=0.1, need_sight=False):
        """Where to search a room again after full turns at ``searched`` [(x, y), ...] found nobody:
        the Pose inside ``polygon``, ``clearance`` [m] from every obstacle (no doorway), that sees the
        last searched spot along a free line, whose distance to the nearest searched spot is nearest
        ``reach`` [m] (far enough for the Kinect to see a person sitting by that spot, near enough
        to see her well), the most open of equals; facing the last spot. When no open place sees the
        last spot (it lies outside the room, behind a wall), the line of sight is not asked, unless
        ``need_sight`` (where to look at somebody from). None when no point qualifies."""
        poly = np.asarray(polygon, dtype=float)
        (x0, y0), (x1, y1) = poly.min(axis=0), poly.max(axis=0)
        xs, ys = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
        pts = np.column_stack([xs.ravel(), ys.ravel()])
        pts = pts[contains_points(poly, pts)]
        room = self.clearance_at(pts)
        ok = (room >= clearance) & ~self.blocked_at(pts)
        pts, room = pts[ok], room[ok]
        if not len(pts) or not searched:
            return None
        spots = np.asarray(searched, dtype=float).reshape(-1, 2)
        last = spots[-1]
        seen = self.line_of_sight(pts, last)
        if need_sight and not seen.any():
            return None
        if seen.any():  # else the last search was outside the room, out of its sight (a sighting from the corridor)
            pts, room = pts[seen], room[seen]
        dist = np.min(np.hypot(pts[:, None, 0] - spots[None, :, 0], pts[:, None, 1] - spots[None, :, 1]), axis=1)
        score = -np.abs(dist - reach) + 0.5 * np.minimum(room, 1.0)
        x, y = pts[int(np.argmax(score))]
        return Pose(float(x), float(y), math.atan2(last[1] - y, last[0] - x))

    def unseen_lookout(self, polygon, searched, near=1.3, far=4.0, clearance=0.45, step=0.2, skip=0.35,
                       min_gain=0.5, occluders=None, person_radius=0.2):
        """Where to search a room again after full turns at ``searched`` [(x, y), ...] found nobody,
        by what those turns could not see: the Pose inside ``polygon``, ``clearance`` [m] from every
        obstacle of this map and of ``occluders``, from which the most floor of the room (its cells of
        ``step`` [m] at least ``person_radius`` [m] from this map's obstacles: where a person can be,
        on a chair too) lies between ``near`` and ``far`` [m] (where the Kinect sees a
        seated person) along a free line, and did not from any searched spot; of equals, the nearest
        the last searched spot; facing the middle of that floor. A line is free of this map's
        obstacles and of ``occluders``' (a Grid: the keep-out map's table tops and chairs, which hide
        a person seated behind them from a Kinect 0.5 m above the floor), its last ``skip`` [m] (the
        person's own chair) not looked at. None when no place sees ``min_gain`` [m^2] of floor not
        seen yet (then :meth:`lookout`)."""
        poly = np.asarray(polygon, dtype=float)
        spots = np.asarray(searched, dtype=float).reshape(-1, 2)
        if not len(spots):
            return None
        (x0, y0), (x1, y1) = poly.min(axis=0), poly.max(axis=0)
        step = max(step, math.sqrt((x1 - x0) * (y1 - y0) / MAX_LOOKOUT_CELLS))  # a hall: coarser, not slower
        xs, ys = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
        cells = np.column_stack([xs.ravel(), ys.ravel()])
        cells = cells[contains_points(poly, cells) & (self.clearance_at(cells) >= person_radius)]
        sight = self if occluders is None else self.with_obstacles(occluders)
        places = cells[sight.clearance_at(cells) >= clearance]
        if not len(cells) or not len(places):
            return None

        def seen_from(xy):
            d = np.hypot(xy[:, None, 0] - cells[None, :, 0], xy[:, None, 1] - cells[None, :, 1])
            return sight.sight_matrix(xy, cells, skip_end=skip, max_length=far) & (d >= near)

        unseen = ~seen_from(spots).any(axis=0)
        newly = seen_from(places) & unseen  # [places, cells]
        gain = newly.sum(axis=1) * step * step  # [m^2]
        best_gain = float(gain.max())
        if best_gain < min_gain:
            return None
        ties = np.flatnonzero(gain >= best_gain - step * step / 2)  # of equals, the nearest the robot
        k = int(ties[np.argmin(np.hypot(*(places[ties] - spots[-1]).T))])
        x, y = places[k]
        new = cells[newly[k]]
        cx, cy = new.mean(axis=0)
        return Pose(float(x), float(y), math.atan2(cy - y, cx - x))


# --- hotspots -----------------------------------------------------------------------------------------------
class Hotspots:
    """Labelled poses, loaded from and saved to one YAML file (atomically). Thread-safe."""

    HEADER = ("# Labelled hotspots (x [m], y [m], phi [rad], map frame) of florenceLocator (seed 3.8).\n"
              "# Written by florence_locator_node (setHotspot) with an atomic rename.\n")

    def __init__(self, spots=None, path=None):
        self.path = None if path is None else str(path)
        self._spots = dict(spots or {})
        self._lock = threading.Lock()

    @classmethod
    def load(cls, path):
        """Hotspots of a hotspots file; YamlError naming the file and line of the first problem."""
        data = load(path)
        if not isinstance(data, dict) or "hotspots" not in data:
            raise YamlError(path, 1, "expected a mapping 'hotspots' of labels to {x, y, phi}")
        entries = data["hotspots"] if data["hotspots"] is not None else {}
        if not isinstance(entries, dict):
            raise YamlError(path, line_of(data, "hotspots"), "'hotspots' must map labels to {x, y, phi}")
        spots = {}
        for label, entry in entries.items():
            try:
                name = check_label(label)
            except ValueError as exc:
                raise YamlError(path, line_of(entries, label), str(exc)) from None
            spots[name] = _pose_entry(entry, path, line_of(entries, label), name)
        return cls(spots, path)

    def labels(self):
        with self._lock:
            return list(self._spots)

    def get(self, label):
        with self._lock:
            return self._spots.get(label)

    def items(self):
        with self._lock:
            return list(self._spots.items())

    def dump(self):
        """The YAML text of the hotspots (the file's content)."""
        with self._lock:
            body = {k: {"x": round(p.x, 6), "y": round(p.y, 6), "phi": round(p.phi, 7)} for k, p in self._spots.items()}
        dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
        return self.HEADER + yaml.dump({"hotspots": body}, Dumper=dumper, default_flow_style=None, sort_keys=False)

    def set(self, label, pose, save=True):
        """Set ``label`` to ``pose`` and, with ``save``, write the file atomically. On a failed write
        (OSError) the previous value is kept in memory as on disk, and the error is raised."""
        name = check_label(label)
        with self._lock:
            previous = self._spots.get(name)
            self._spots[name] = pose
        if save and self.path is not None:
            try:
                atomic_write(self.path, self.dump().encode("utf-8"))
            except OSError:
                with self._lock:
                    if previous is None:
                        self._spots.pop(name, None)
                    else:
                        self._spots[name] = previous
                raise
        return name
