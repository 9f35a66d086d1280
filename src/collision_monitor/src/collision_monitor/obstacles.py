"""Obstacle points from one range sensor, with a short memory of what it can no longer see
(ROS-free).

Each scan's returns replace the sensor's points, in a fixed frame (odom) so that they stay where
they are while the robot moves between scans. A point of an earlier scan that the new scan cannot
observe is remembered: one outside the new scan's angular span (beside or behind the robot) or
hidden behind a nearer return for ``memory`` s after it was last seen; one in the sensor's blind
zone in front, nearer than its ``range_min`` (the Kinect sees nothing nearer than about 0.5 m: a
chair seat it saw on the way in is still there when it is too near to see), for as long as it is
there, and ``memory`` s once the robot turned away from it. A remembered point the new scan looks
at and sees through is gone (it moved away). A person who left the blind zone unseen is an obstacle
until the robot backs off far enough to see the place again: the safe mistake.

A scan flattens what it sees: a farther return at a bearing "sees through" everything nearer at that
bearing, even what lies below the ray (the Kinect's fake laser close to a chair seat, issue 19). A
depth camera is better given as a depth image (``type: depth``): depth_memory.DepthMemory keeps its
points in 3-D and clears them only by the pixels that look at them.
"""

import math
import posixpath
from dataclasses import dataclass

import numpy as np

from collision_monitor.depth_memory import DepthMemory
from florence_common.params import Param, ParamError, ParamTable
from florence_common.scan import scan_points

# One entry of the node's ~sources list (config/sources.yaml). The fields after ``memory`` are a
# depth source's (depth_memory.DepthMemory); a scan source given one is refused.
SCAN, DEPTH = "scan", "depth"
SOURCE = ParamTable(
    Param("name", str, None, "the source's name in /diagnostics and ~state (required)", optional=True),
    Param("topic", str, None, "its sensor_msgs/LaserScan topic, or a depth source's sensor_msgs/Image (32FC1 [m] "
          "or 16UC1 [mm]) (required)", optional=True),
    Param("type", str, SCAN, "scan: a LaserScan, remembered in 2-D (obstacles.ObstacleMemory); depth: a depth "
          "image, remembered in 3-D and cleared only by the pixels that look at a point (depth_memory.DepthMemory)",
          choices=(SCAN, DEPTH)),
    Param("timeout", float, 0.5, "a source silent this long is stale", unit="s", gt=0),
    Param("required", bool, True, "while it is stale the monitor stops every linear motion (turning in place "
          "passes); an optional source does so only once it has been heard from (a robot without it is only "
          "warned about)"),
    Param("self_range", float, 0.0, "returns nearer than this to the sensor are the robot's own structure", unit="m",
          ge=0),
    Param("padding", float, 0.0, "the clearance to this sensor's points counts this much less (a sensor that may "
          "place an obstacle's edge beyond it)", unit="m", ge=0),
    Param("memory", float, 3.0, "how long points the sensor can no longer see (beside or behind the robot, hidden) "
          "are remembered; what is too near for it in front is kept as long as it is there", unit="s", ge=0),
    Param("camera_info", str, "", "depth: the image's sensor_msgs/CameraInfo topic (empty: camera_info beside "
          "topic)"),
    Param("min_height", float, 0.05, "depth: lowest point kept, z in ~fixed_frame (the floor)", unit="m"),
    Param("max_height", float, 1.0, "depth: highest point kept", unit="m"),
    Param("max_range", float, 3.0, "depth: farthest point kept, along the optical axis", unit="m", gt=0),
    Param("blind_range", float, 0.7, "depth: a remembered point in front of the camera (its optical axis' half-space) "
          "this near to it (horizontally) that it does not see (no depth at its pixel; beside, above or below the "
          "image) and that it last saw from this near is too near for it: kept as long as it is there", unit="m",
          ge=0),
    Param("target_width", int, 160, "depth: fresh points from about this many columns (every "
          "round(width / target_width)-th row and column); remembered points are judged at every pixel", unit="px",
          ge=1),
    Param("resolution", float, 0.03, "depth: one point is kept per cube of this edge; commands are judged against "
          "one per column of this square", unit="m", gt=0),
    Param("support_radius", float, 0.0, "depth: a point the camera cannot see now (too near, or beside, above or "
          "below the view) that had a return of the scan sources (the laser, at floor level) this near when last "
          "seen and has none now is dropped: what held it up left (a person who got up and walked away, or walked "
          "on ahead of the robot); a chair's legs stay (0: off)", unit="m", ge=0),
    prefix="",
)
DEPTH_ONLY = ("camera_info", "min_height", "max_height", "max_range", "blind_range", "target_width", "resolution",
              "support_radius")


def parse_sources(raw):
    """The validated ``~sources`` list (Params each); ParamError naming the offending entry."""
    if not isinstance(raw, list) or not raw:
        raise ParamError(f"~sources must be a non-empty list of {{{', '.join(SOURCE.names())}}}, got {raw!r}")
    sources = []
    for i, entry in enumerate(raw):
        if not isinstance(entry, dict):
            raise ParamError(f"~sources[{i}] must be a mapping, got {entry!r}")
        try:
            source = SOURCE.validate(entry)
        except ParamError as exc:
            raise ParamError(f"~sources[{i}] ({entry.get('name', '?')}): {exc}") from None
        for key in ("name", "topic"):
            if not source[key]:
                raise ParamError(f"~sources[{i}]: {key} must be a non-empty string, got {source[key]!r}")
        where = f"~sources[{i}] ({source.name})"
        if source.type == SCAN and set(entry) & set(DEPTH_ONLY):
            raise ParamError(f"{where}: {', '.join(sorted(set(entry) & set(DEPTH_ONLY)))} only apply to type depth")
        if source.min_height > source.max_height:
            raise ParamError(f"{where}: min_height {source.min_height} > max_height {source.max_height}")
        sources.append(source)
    for attr in ("name", "topic"):
        values = [s[attr] for s in sources]
        dupes = sorted({v for v in values if values.count(v) > 1})
        if dupes:
            raise ParamError(f"~sources: {attr}s must be unique, repeated: {dupes}")
    return sources


def camera_info_topic(source):
    """The CameraInfo topic of a depth source: its ``camera_info``, or camera_info beside its image
    topic (/camera/depth/image -> /camera/depth/camera_info)."""
    if source.camera_info:
        return source.camera_info
    return posixpath.join(posixpath.dirname(source.topic), "camera_info")


def make_memory(source):
    """The memory for a parsed source: ObstacleMemory for a scan, DepthMemory for a depth image."""
    if source.type == DEPTH:
        return DepthMemory(source.memory, source.min_height, source.max_height, source.max_range, source.blind_range,
                           source.self_range, target_width=source.target_width, resolution=source.resolution,
                           support_radius=source.support_radius)
    return ObstacleMemory(source.memory, source.self_range)


@dataclass(frozen=True)
class Scan:
    """One scan: the LaserScan fields that matter and the 4x4 pose of its frame in the fixed frame."""

    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    pose: np.ndarray  # 4x4 [m]
    stamp: float  # [s]


class ObstacleMemory:
    """The obstacle points [N, 3] of one sensor in the fixed frame.

    ``self_range`` [m]: returns nearer than this to the sensor are the robot's own structure
    (the Hokuyo sees its standoffs at 0.13 m) and dropped; ``occlusion_margin`` [m]: a remembered
    point this much behind a return counts as hidden by it."""

    def __init__(self, memory=3.0, self_range=0.0, occlusion_margin=0.1):
        if not (memory >= 0 and self_range >= 0 and occlusion_margin >= 0):
            raise ValueError("memory, self_range and occlusion_margin must be >= 0")
        self.memory = float(memory)
        self.self_range = float(self_range)
        self.occlusion_margin = float(occlusion_margin)
        self.points = np.zeros((0, 3))
        self.seen_at = np.zeros(0)  # [s] when each point was last seen
        self.stamp = -math.inf  # [s] of the last scan

    def update(self, scan):
        """Take a scan; returns the number of points remembered from before."""
        r = np.asarray(scan.ranges, dtype=float)
        fresh, _ = scan_points(r, scan.angle_min, scan.angle_increment, max(scan.range_min, self.self_range),
                               scan.range_max, scan.pose)
        unobserved, blind = self._unobserved(scan, r)
        # a point in the blind zone in front stays as long as it is there: the robot stands before it
        self.seen_at[blind] = float(scan.stamp)
        keep = unobserved & (scan.stamp - self.seen_at <= self.memory)
        self.points = np.vstack([fresh, self.points[keep]])
        self.seen_at = np.concatenate([np.full(len(fresh), float(scan.stamp)), self.seen_at[keep]])
        self.stamp = float(scan.stamp)
        return int(np.count_nonzero(keep))

    def _unobserved(self, scan, ranges):
        """(which of the current points the new scan cannot observe, which of those lie in its blind
        zone: inside its angular span but too near for it)."""
        if not len(self.points):
            return np.zeros(0, dtype=bool), np.zeros(0, dtype=bool)
        inv = np.linalg.inv(np.asarray(scan.pose, dtype=float))
        local = self.points @ inv[:3, :3].T + inv[:3, 3]
        rng = np.hypot(local[:, 0], local[:, 1])
        beam = np.rint((np.arctan2(local[:, 1], local[:, 0]) - scan.angle_min) / scan.angle_increment)
        outside = (beam < 0) | (beam >= len(ranges))
        measured = ranges[np.clip(beam, 0, len(ranges) - 1).astype(int)]
        # a return in front of the point hides it; no echo (+inf) ran free to range_max; an error
        # (NaN) or a too-near reading tells nothing
        seen_to = np.where(np.isposinf(measured), scan.range_max, measured)
        unknown = ~np.isfinite(seen_to) | (seen_to <= scan.range_min)
        with np.errstate(invalid="ignore"):
            hidden = rng > seen_to + self.occlusion_margin
        near = rng <= max(scan.range_min, self.self_range)
        far = rng >= scan.range_max
        return outside | unknown | hidden | near | far, near & ~outside

    def clear(self):
        self.points, self.seen_at = np.zeros((0, 3)), np.zeros(0)

    def age(self, now):
        """[s] since the last scan."""
        return now - self.stamp
