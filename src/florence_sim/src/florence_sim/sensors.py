"""Sensor models: the Hokuyo URG-04LX and the Kinect depth/RGB camera (no ROS).

Mount poses are 4x4 matrices in ``base_footprint`` taken from the robot
description; a robot pose (x, y, yaw) places them in the world. Each model
returns what the real driver would put in its message, in the sensor's own
frame: the laser does not know it is upside down, tf does.
"""

import itertools
import math
from dataclasses import dataclass

import numpy as np

from florence_sim.geometry import Cylinder

# Hokuyo URG-04LX (datasheet; hokuyo_node): 1024 steps a turn, steps 44..725 usable with
# the front at step 384, i.e. +-340 steps = +-2.0862 rad; 20 mm .. 5.6 m; 100 ms a scan.
URG_STEPS_PER_TURN = 1024
URG_MAX_STEP = 340  # [steps] from the front, both sides
URG_RANGE_MIN = 0.02  # [m]
URG_RANGE_MAX = 5.6  # [m]
URG_SCAN_TIME = 0.1  # [s]
URG_NO_RETURN = float("inf")  # [m] our hokuyo_node publishes the URG's error codes as +inf (REP 117)


def world_pose(x, y, yaw):
    """4x4 pose of base_footprint in the world."""
    c, s = math.cos(yaw), math.sin(yaw)
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    m[0, 3], m[1, 3] = x, y
    return m


@dataclass
class LaserConfig:
    min_ang: float = -math.pi / 2  # [rad] requested first angle (hokuyo_node ~min_ang)
    max_ang: float = math.pi / 2  # [rad] requested last angle (hokuyo_node ~max_ang)
    noise: float = 0.01  # [m] range noise std below 1 m; 1 % of the range beyond (URG: +-10 mm / 1 %)
    frame_id: str = "base_laser_link"
    self_hits: bool = False  # the beams also hit the robot's own standoffs, as on the real robot


class UrgLaser:
    """Scans in the laser's own frame, counter-clockwise about its own z axis, as the URG does."""

    def __init__(self, mount, config=None, rng=None, robot_cylinders=()):
        """``robot_cylinders``: (name, x, y, radius, z0, z1) of the robot in base_footprint [m];
        with ``self_hits`` those crossing the scan plane are seen (the laser's own parts are not)."""
        self.cfg = config or LaserConfig()
        self.mount = np.asarray(mount, dtype=float)
        h = self.mount[2, 3]
        self.robot_cylinders = [c for c in robot_cylinders if c[4] <= h <= c[5] and not c[0].startswith("base_laser")]
        if abs(abs(self.mount[2, 2]) - 1.0) > 1e-6:
            raise ValueError("the laser's z axis must be vertical (up or down) for a 2D scan")
        self.rng = rng or np.random.default_rng(1)
        self.increment = 2 * math.pi / URG_STEPS_PER_TURN  # [rad]
        lo, hi = self.cfg.min_ang, self.cfg.max_ang
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi:
            raise ValueError(f"min_ang {lo} must be below max_ang {hi}")
        # hokuyo_node turns the requested angles into device steps and clips them to the device
        first = max(-URG_MAX_STEP, min(URG_MAX_STEP, round(lo / self.increment)))
        last = max(-URG_MAX_STEP, min(URG_MAX_STEP, round(hi / self.increment)))
        self.steps = np.arange(first, last + 1)
        self.angles = self.steps * self.increment  # [rad] in the laser frame
        self.angle_min = float(self.angles[0])
        self.angle_max = float(self.angles[-1])
        local = np.stack([np.cos(self.angles), np.sin(self.angles), np.zeros_like(self.angles)], axis=1)
        self._dirs_base = local @ self.mount[:3, :3].T  # beam directions in base_footprint
        self.time_increment = URG_SCAN_TIME / URG_STEPS_PER_TURN  # [s]
        self.scan_time = URG_SCAN_TIME
        self.range_min, self.range_max = URG_RANGE_MIN, URG_RANGE_MAX

    def scan(self, scene, x, y, yaw):
        """Ranges [m] (float32) of one scan from robot pose (x, y, yaw); no echo -> +inf."""
        pose = world_pose(x, y, yaw) @ self.mount
        dirs = self._dirs_base[:, :2] @ world_pose(0, 0, yaw)[:2, :2].T
        if self.cfg.self_hits and self.robot_cylinders:
            c, s = math.cos(yaw), math.sin(yaw)
            scene = scene.with_cylinders([Cylinder(f"robot/{n}", x + c * cx - s * cy, y + s * cx + c * cy, r, z0, z1)
                                          for n, cx, cy, r, z0, z1 in self.robot_cylinders])
        ranges, _ = scene.cast_2d(pose[:2, 3], dirs, pose[2, 3], self.range_max)
        hit = np.isfinite(ranges)
        if self.cfg.noise:
            sigma = np.maximum(self.cfg.noise, self.cfg.noise * ranges[hit])
            ranges[hit] += self.rng.normal(0.0, 1.0, hit.sum()) * sigma
        valid = hit & (ranges >= self.range_min) & (ranges <= self.range_max)
        return np.where(valid, ranges, URG_NO_RETURN).astype(np.float32)


# Kinect (PrimeSense) edge artefacts. The IR projector sits 7.5 cm to the right of the IR camera
# (+x of the depth optical frame): a surface point the projector cannot light returns no depth,
# i.e. a band on the far surface to the left (-x) of every nearer object, b * fx * (1/z_near -
# 1/z_far) px wide (2.3 px at 160x120 for a person at 2 m before a wall at 3.5 m). Pixels that
# straddle a depth jump (mixed pixels) return none either; we drop the farther side of each jump.
PROJECTOR_BASELINE = 0.075  # [m] IR projector to IR camera, along +x of the depth optical frame
EDGE_JUMP = 0.1  # a neighbour nearer by more than this fraction of a pixel's depth makes it an edge
EDGE_DROPOUT_MAX = 8  # [px] the widest edge dropout accepted


@dataclass
class CameraConfig:
    width: int = 160  # [px]
    height: int = 120  # [px]
    hfov: float = math.radians(58.0)  # [rad] horizontal field of view (square pixels)
    min_range: float = 0.55  # [m] nothing nearer is seen (NaN)
    max_range: float = 4.0  # [m]
    # [1/m] depth noise std = depth_noise * depth^2 (structured light): 4 cm at 5 m, 1.4 cm at 3 m,
    # as Khoshelham and Elberink 2012 (Sensors 12(2): 1437-1454) measured the Kinect
    depth_noise: float = 0.0016
    # [px] depth lost at object edges (0: none): the farther side of every depth jump (more than
    # EDGE_JUMP of its depth, to another primitive) over this many pixels, and the projector's shadow
    edge_dropout: int = 1
    floor_color: tuple = (0.62, 0.52, 0.40)
    ceiling_color: tuple = (0.95, 0.95, 0.95)

    def validate(self):
        if not (8 <= self.width <= 640 and 6 <= self.height <= 480):
            raise ValueError(f"camera size {self.width}x{self.height} must be within 8x6 .. 640x480")
        if not (0 < self.hfov < math.pi):
            raise ValueError("hfov must be within 0..pi")
        if not (0 <= self.min_range < self.max_range):
            raise ValueError("need 0 <= min_range < max_range")
        if self.depth_noise < 0:
            raise ValueError("depth_noise must be >= 0")
        if isinstance(self.edge_dropout, bool) or not isinstance(self.edge_dropout, int) \
                or not 0 <= self.edge_dropout <= EDGE_DROPOUT_MAX:
            raise ValueError(f"edge_dropout must be an int within 0..{EDGE_DROPOUT_MAX} px, got {self.edge_dropout!r}")
        return self


class DepthCamera:
    """A pinhole camera in an optical frame (z forward, x right, y down)."""

    STRIPS = 8  # column strips, each with its own primitive culling

    def __init__(self, config=None, rng=None):
        self.cfg = (config or CameraConfig()).validate()
        self.rng = rng or np.random.default_rng(2)
        w, h = self.cfg.width, self.cfg.height
        self.fx = self.fy = (w / 2) / math.tan(self.cfg.hfov / 2)  # [px]
        self.cx, self.cy = (w - 1) / 2, (h - 1) / 2
        u, v = np.meshgrid(np.arange(w), np.arange(h))
        self.rays = np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones_like(u, dtype=float)],
                             axis=-1).reshape(-1, 3)  # optical frame, z = 1
        # rays ordered strip by strip (columns), so that each strip is a contiguous slice
        cols = np.tile(np.arange(w), h)
        edges = np.linspace(0, w, min(self.STRIPS, w) + 1).astype(int)
        strips = [np.nonzero((cols >= a) & (cols < b))[0] for a, b in itertools.pairwise(edges)]
        self.order = np.concatenate(strips)  # ray index in strip order -> pixel index
        self.unorder = np.argsort(self.order)  # pixel index -> ray index in strip order
        starts = np.cumsum([0] + [len(g) for g in strips])
        self.groups = [slice(a, b) for a, b in itertools.pairwise(starts)]
        self._ordered_rays = self.rays[self.order]
        self._bounds = {}  # optical-axis elevation -> per-strip angle bounds
        self._columns = np.arange(w, dtype=np.float32)  # [px] u of each image column
        self._normals = self.rng.standard_normal(w * h + (1 << 16), dtype=np.float32)

    def _strip_bounds(self, rot):
        """Horizontal angle interval of each strip relative to the optical axis's heading.

        It depends only on the camera's elevation (tilt), not on the robot's yaw: cached."""
        axis = rot[:, 2]
        key = round(float(axis[2]), 6)
        if key not in self._bounds:
            heading = math.atan2(axis[1], axis[0])
            c, s = math.cos(-heading), math.sin(-heading)
            level = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ rot
            dirs = self._ordered_rays @ level.T
            angles = np.arctan2(dirs[:, 1], dirs[:, 0])
            self._bounds[key] = [(angles[g].min(), angles[g].max()) for g in self.groups]
        return self._bounds[key]

    @property
    def K(self):
        return [self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0]

    def render(self, scene, optical_pose, noise=True, color=True):
        """Depth [m] (H, W) float32 with NaN for no return, and RGB (H, W, 3) uint8 (None
        unless ``color``), for an optical frame at ``optical_pose`` (4x4 in the world)."""
        cfg = self.cfg
        rot = optical_pose[:3, :3]
        dirs = self._ordered_rays @ rot.T
        heading = math.atan2(rot[1, 2], rot[0, 2])
        depth, owner = scene.cast_3d(optical_pose[:3, 3], dirs, cfg.max_range, self.groups, heading,
                                     self._strip_bounds(rot))
        depth, owner = depth[self.unorder], owner[self.unorder]
        h, w = cfg.height, cfg.width
        edges = self.edge_mask(depth.reshape(h, w), owner.reshape(h, w)).ravel() if cfg.edge_dropout else None
        rgb = None
        if color:
            table = np.concatenate([scene.colors, [cfg.ceiling_color, cfg.floor_color, (0, 0, 0)]]).astype(np.float32)
            shade = np.clip(1.0 - 0.12 * np.minimum(depth, cfg.max_range), 0.4, 1.0)
            rgb = (table[np.where(owner < 0, len(scene.colors) + 3 + owner, owner)] * (255 * shade[:, None]))
            rgb = rgb.astype(np.uint8).reshape(h, w, 3)
        with np.errstate(invalid="ignore"):
            if noise and cfg.depth_noise:
                # a random window of a pre-drawn normal table: drawing 19200 normals a frame costs more
                start = int(self.rng.integers(0, len(self._normals) - len(depth)))
                depth += self._normals[start:start + len(depth)] * np.float32(cfg.depth_noise) * depth * depth
            depth[~np.isfinite(depth) | (depth < cfg.min_range)] = np.nan
        if edges is not None:
            depth[edges] = np.nan
        return depth.reshape(h, w), rgb

    def edge_mask(self, depth, owner):
        """Pixels (H, W) bool that return no depth at object edges, from the noiseless depth
        [m] (H, W) (``inf``: no hit) and the primitive each pixel sees (H, W):

        - mixed pixels: a pixel whose neighbour up to ``edge_dropout`` pixels away along its row
          or column sees another primitive nearer than (1 - EDGE_JUMP) times its depth (the
          farther side of every jump; a steep but continuous surface such as the floor far
          ahead is one primitive and keeps its depth);
        - the projector's shadow: a pixel whose projector column u - b * fx / z (b:
          PROJECTOR_BASELINE) is not left of every projector column to its right in its row
          is hidden from the projector by something nearer (right of it in the image).
        Vectorised: a few whole-image comparisons and a reverse running minimum per row."""
        drop = np.zeros(depth.shape, dtype=bool)
        near = depth * np.float32(1.0 - EDGE_JUMP)  # a neighbour below this makes an edge
        for k in range(1, self.cfg.edge_dropout + 1):
            other = owner[:, k:] != owner[:, :-k]  # across k columns
            drop[:, :-k] |= other & (depth[:, k:] < near[:, :-k])  # the neighbour to the right is nearer
            drop[:, k:] |= other & (depth[:, :-k] < near[:, k:])  # the neighbour to the left
            other = owner[k:] != owner[:-k]  # across k rows
            drop[:-k] |= other & (depth[k:] < near[:-k])
            drop[k:] |= other & (depth[:-k] < near[k:])
        with np.errstate(divide="ignore"):
            projector = self._columns - np.float32(PROJECTOR_BASELINE * self.fx) / depth  # [px]; inf -> u
        right_min = np.minimum.accumulate(projector[:, :0:-1], axis=1)[:, ::-1]  # min over columns u+1..
        drop[:, :-1] |= projector[:, :-1] >= right_min
        return drop

    def points(self, depth):
        """Points (H, W, 3) [m] in the optical frame for a depth image (NaN stays NaN)."""
        return self.rays.reshape(self.cfg.height, self.cfg.width, 3) * depth[..., None]
