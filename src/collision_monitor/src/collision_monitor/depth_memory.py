"""Obstacle points from a depth camera, with a 3-D memory cleared only by 3-D rays (ROS-free).

Why not the camera's fake laser: a LaserScan flattens the view, so a farther return at a bearing
looks like a ray through everything nearer at that bearing. Close up, a chair seat's near edge
(0.45 m high) leaves the Kinect's depth range (nothing nearer than about 0.5 m) while rays passing
*above* that edge still see the seat's far part; in 2-D that return "sees through" the remembered
edge and clears it (issue 19: follow_me crept into the seat). Here a remembered point is judged
by the pixel that looks at it in 3-D.

Frames and units: the camera's optical frame (z forward along the optical axis, x right, y down)
[m]; a depth image holds each pixel's z [m] (NaN: no return); intrinsics fx, fy, cx, cy [px] with
pixel (u, v) centred at integer coordinates (sensor_msgs/CameraInfo's K). Points are kept in a
fixed frame (odom) whose z is the height above the floor.

Each frame:

1. *Fresh points*: every ``stride``-th row and column (``stride`` from ``target_width``) is
   back-projected, placed in the fixed frame and kept when it lies in the height band
   [``min_height``, ``max_height``] (as the fake laser's) and its depth in
   (``self_range``, ``max_range``]; then thinned to one point per ``resolution`` voxel.
2. *Remembered points* are projected into the new image (every pixel, not only the subsampled
   ones) and judged (:func:`classify`):

   - BLIND: in front of the camera (the half-space its optical axis points into) within
     ``blind_range`` of it in the horizontal plane, where it does not see the point: outside the
     image (beside it, above or below) or on a pixel without depth (too near: a seat the robot
     drove up to), *and last seen from within blind_range*. Kept as long as it is there, like
     ObstacleMemory's blind zone (the fake laser kept what was nearer than its range_min over its
     +-90 degrees): the robot may turn or arc into what is beside it. A point last seen from
     farther that comes this near unseen is UNKNOWN: a person's feet or shoulders, seen from 1.1 m
     and more by a robot following them, leave the bottom or the top of the view before the robot
     reaches the place (below about 0.15 m or above 0.95 m at 1 m); kept for good, they stopped
     the robot on the person's track;
   - BEHIND the camera, or OUTSIDE the image farther away: not observed, kept for ``memory`` s
     after last seen; UNKNOWN, on a pixel without depth farther away (no return): the same;
   - SEEN_THROUGH when the pixel and every pixel with depth next to it read more than ``margin``
     beyond the point: the ray passed where the point was: dropped;
   - HIDDEN behind a return nearer by more than ``margin`` (or an uneven neighbourhood): kept for
     ``memory`` s;
   - OBSERVED otherwise (the pixel reads the point's depth): dropped, the frame's fresh points
     stand for it.
3. Fresh points first, then the kept ones; a kept point whose voxel already holds a fresh point
   goes (one point per voxel). ``columns`` holds one of them per vertical column of
   ``resolution`` square: the obstacles in the plane, what the monitor judges a command against
   (about 30 times fewer than the 3-D points).

A person who walks away is cleared by the pixels that now see the wall behind where they stood.
What was seen near and leaves the view unseen stays (the safe mistake): the parts of a person who
stood within blind_range that are above or below the view remain an obstacle in front until the
robot turns away or backs off far enough to see the place again (or is told to forget: the node's
~forget, after the robot was carried), unless the laser shows that what held it up left
(``support_radius``, :meth:`DepthMemory.update`): then BLIND, UNKNOWN and OUTSIDE points go at once.
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from florence_common.camera import Camera, stride_for

# the verdict on a remembered point (classify)
OBSERVED, SEEN_THROUGH, HIDDEN, BEHIND, OUTSIDE, BLIND, UNKNOWN = range(7)
VERDICTS = ("observed", "seen through", "hidden", "behind", "outside", "blind", "unknown")
KEPT = np.array([False, False, True, True, True, True, True])  # per verdict: not dropped
# a held point (support_radius) with one of these verdicts and no floor-level return near now is dropped:
# the camera cannot see it (too near, or beside, above or below its view), the laser sees what held it gone
RELEASED_BY_SUPPORT = (BLIND, UNKNOWN, OUTSIDE)
_VOXEL_SPAN = 1 << 20  # voxel index range per axis (+-2**19 voxels: +-15 km at 3 cm)


@dataclass(frozen=True)
class DepthFrame:
    """One depth image: ``depth`` [H, W] float [m] along the optical axis (NaN, 0 or inf: no
    return), its ``camera``, ``pose`` the 4x4 pose of its optical frame in the fixed frame,
    ``stamp`` [s]."""

    depth: np.ndarray
    camera: Camera
    pose: np.ndarray
    stamp: float


def voxel_keys(points, resolution, dims=3):
    """One int64 key per point [N, 3] of the voxel of edge ``resolution`` [m] holding it (``dims``
    2: of the vertical column)."""
    idx = np.floor(np.asarray(points, dtype=float)[:, :dims] / resolution).astype(np.int64) + _VOXEL_SPAN // 2
    idx = np.clip(idx, 0, _VOXEL_SPAN - 1)
    keys = idx[:, 0] * _VOXEL_SPAN + idx[:, 1]
    return keys * _VOXEL_SPAN + idx[:, 2] if dims == 3 else keys


def to_camera(points, pose):
    """``points`` [N, 3] of the fixed frame in the optical frame whose 4x4 pose is ``pose``."""
    m = np.asarray(pose, dtype=float)
    return (np.asarray(points, dtype=float) - m[:3, 3]) @ m[:3, :3]


def classify(points, frame, blind_range, margin, seen_from=None):
    """The verdict (OBSERVED ... UNKNOWN, see the module) on each remembered point [N, 3] of the
    fixed frame in ``frame``; ``blind_range`` [m]: a point in front of the camera this near to it
    in the horizontal plane (hypot of optical x and z: the camera's height and tilt aside) that it
    does not see is too near for it, if it was last seen from within that distance (``seen_from``
    [N] [m]: the distance it was last seen from; None: all were); ``margin`` [m] of depth between
    a point and a return beyond or before it."""
    n = len(points)
    verdict = np.full(n, OBSERVED, dtype=np.int8)
    if not n:
        return verdict
    cam = frame.camera
    local = to_camera(points, frame.pose)
    z = local[:, 2]
    behind = ~(z > 1e-3)
    zs = np.where(behind, 1.0, z)
    u = np.rint(cam.fx * local[:, 0] / zs + cam.cx)
    v = np.rint(cam.fy * local[:, 1] / zs + cam.cy)
    outside = ~behind & ((u < 0) | (u >= cam.width))
    near = ~behind & (np.hypot(local[:, 0], z) <= blind_range)
    if seen_from is not None:
        near &= np.asarray(seen_from) <= blind_range
    in_view = ~behind & ~outside
    depth = np.asarray(frame.depth, dtype=np.float32)
    h, w = depth.shape
    ui, vi = np.clip(u, 0, w - 1).astype(np.intp), np.clip(v, 0, h - 1).astype(np.intp)
    d = depth[vi, ui].astype(float)
    with np.errstate(invalid="ignore"):
        no_depth = ~(np.isfinite(d) & (d > 0)) | (v < 0) | (v >= h)
    unseen = in_view & no_depth
    # the least depth around the pixel (itself and its 8 neighbours with a return)
    least = d.copy()
    for dv in (-1, 0, 1):
        for du in (-1, 0, 1):
            nd = depth[np.clip(vi + dv, 0, h - 1), np.clip(ui + du, 0, w - 1)].astype(float)
            with np.errstate(invalid="ignore"):
                nd = np.where(np.isfinite(nd) & (nd > 0), nd, np.inf)
            least = np.minimum(least, nd)
    looked = in_view & ~no_depth
    with np.errstate(invalid="ignore"):
        through = looked & (least > z + margin)
        observed = looked & ~through & (np.abs(d - z) <= margin)
    verdict[:] = HIDDEN  # what is left: a nearer return, or beyond with something near beside it
    verdict[observed] = OBSERVED
    verdict[through] = SEEN_THROUGH
    verdict[unseen] = UNKNOWN
    verdict[outside] = OUTSIDE
    verdict[near & (unseen | outside)] = BLIND
    verdict[behind] = BEHIND
    return verdict


class DepthMemory:
    """The obstacle points [N, 3] of one depth camera in the fixed frame (see the module).

    ``memory`` [s]: how long a point the camera no longer observes is kept (BLIND ones: as long as
    they are blind); ``min_height``, ``max_height`` [m]: the band of fixed-frame z kept;
    ``max_range`` [m]: depth of the farthest fresh point; ``blind_range`` [m]: the camera sees
    nothing nearer (in front, see classify); ``self_range`` [m]: nearer returns are the robot itself; ``margin``
    [m]: depth difference that counts as seeing through or hidden; ``target_width`` [px]: columns
    used for fresh points; ``resolution`` [m]: voxel edge of the thinning."""

    def __init__(self, memory=3.0, min_height=0.05, max_height=1.0, max_range=3.0, blind_range=0.7,
                 self_range=0.0, margin=0.1, target_width=160, resolution=0.03, support_radius=0.0):
        if not (memory >= 0 and self_range >= 0 and margin >= 0 and blind_range >= 0):
            raise ValueError("memory, self_range, margin and blind_range must be >= 0")
        if not (min_height <= max_height and max_range > 0 and target_width >= 1 and resolution > 0):
            raise ValueError("need min_height <= max_height, max_range > 0, target_width >= 1, resolution > 0")
        self.memory, self.margin, self.blind_range = float(memory), float(margin), float(blind_range)
        self.min_height, self.max_height = float(min_height), float(max_height)
        self.max_range, self.self_range = float(max_range), float(self_range)
        self.target_width, self.resolution = int(target_width), float(resolution)
        self.support_radius = float(support_radius)
        self.points = np.zeros((0, 3))
        self.held = np.zeros(0, dtype=bool)  # a floor-level return was within support_radius when last seen
        self.seen_at = np.zeros(0)  # [s] when each point was last seen
        self.seen_from = np.zeros(0)  # [m] from how far (horizontally) each point was last seen
        self.columns = np.zeros((0, 3))  # one of the points per column of resolution square
        self.stamp = -math.inf  # [s] of the last frame
        self.counts = np.zeros(len(VERDICTS), dtype=int)  # verdicts of the last frame
        self.cleared = 0  # clear() calls: an update running meanwhile keeps only its fresh points

    def fresh_points(self, frame):
        """The frame's obstacle points [N, 3] in the fixed frame (before thinning)."""
        return self._fresh(frame)[0]

    def _fresh(self, frame):
        """(the frame's obstacle points [N, 3] in the fixed frame, the distance [N] [m] each was seen
        from in the camera's horizontal plane)."""
        cam = frame.camera
        depth = np.asarray(frame.depth, dtype=np.float32)
        if depth.shape != (cam.height, cam.width):
            raise ValueError(f"a {depth.shape[1]}x{depth.shape[0]} image with a {cam.width}x{cam.height} camera")
        stride = stride_for(cam.width, self.target_width)
        z = depth[::stride, ::stride].ravel().astype(float)
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(z) & (z > self.self_range) & (z > 0) & (z <= self.max_range)
        m = np.asarray(frame.pose, dtype=float)
        rays = cam.rays(stride).reshape(-1, 3)[ok]
        local = rays * z[ok, None]
        pts = local @ m[:3, :3].T + m[:3, 3]
        band = (pts[:, 2] >= self.min_height) & (pts[:, 2] <= self.max_height)
        return pts[band], np.hypot(local[band, 0], local[band, 2])

    def _near_support(self, points, tree):
        """Which ``points`` [N, 3] have a floor-level return within support_radius (``tree``: a cKDTree of
        the returns, or None: none has)."""
        if tree is None or not len(points):
            return np.zeros(len(points), dtype=bool)
        d, _ = tree.query(points[:, :2], distance_upper_bound=self.support_radius)
        return np.isfinite(d)

    def update(self, frame, support=None):
        """Take a frame; returns the number of points remembered from before. ``support`` [K, 2]:
        floor-level returns (the laser's points, x and y in the fixed frame) or None. With
        ``support_radius`` > 0, a point the camera cannot see now (BLIND, UNKNOWN or OUTSIDE: too
        near, or beside, above or below the view) that had such a return within support_radius when
        it was last seen and has none now is dropped: what held it up left (a person who stood up and
        walked away, or walked on ahead of a robot following her, above and below the view); a
        chair's legs stay, and a table top's edge far from its legs was never held. BEHIND and
        HIDDEN points are not: the laser may not see there either."""
        cleared = self.cleared
        old_points, old_seen_at, old_from, old_held = self.points, self.seen_at, self.seen_from, self.held
        fresh, fresh_from = self._fresh(frame)
        verdict = classify(old_points, frame, self.blind_range, self.margin, old_from)
        use_support = support is not None and self.support_radius > 0.0
        tree = cKDTree(np.asarray(support, dtype=float)[:, :2]) if use_support and len(support) else None
        if use_support:
            unseen = np.isin(verdict, RELEASED_BY_SUPPORT)
            verdict[unseen & old_held & ~self._near_support(old_points, tree)] = SEEN_THROUGH
        self.counts = np.bincount(verdict, minlength=len(VERDICTS))
        stamp = float(frame.stamp)
        seen_at = np.where(verdict == BLIND, stamp, old_seen_at)  # blind in front: kept while it is there
        keep = KEPT[verdict] & (stamp - seen_at <= self.memory)
        fresh_held = self._near_support(fresh, tree)
        kept = self._store(np.vstack([fresh, old_points[keep]]),
                           np.concatenate([np.full(len(fresh), stamp), seen_at[keep]]),
                           np.concatenate([fresh_from, old_from[keep]]), len(fresh),
                           np.concatenate([fresh_held, old_held[keep]]))
        if self.cleared != cleared:  # cleared by another thread meanwhile: only this frame's points
            kept = self._store(fresh, np.full(len(fresh), stamp), fresh_from, len(fresh), fresh_held)
        self.stamp = stamp
        return kept

    def _store(self, points, seen_at, seen_from, fresh, held):
        """Keep one of ``points`` (the first ``fresh`` of them this frame's) per voxel, the first;
        returns how many of the kept ones are not fresh."""
        _, first = np.unique(voxel_keys(points, self.resolution), return_index=True)
        first.sort()
        points, seen_at, seen_from, held = points[first], seen_at[first], seen_from[first], held[first]
        _, column = np.unique(voxel_keys(points, self.resolution, dims=2), return_index=True)
        # replaced whole, each in one assignment: a reader in another thread sees one frame's arrays
        self.points, self.seen_at, self.seen_from, self.held = points, seen_at, seen_from, held
        self.columns = points[column]
        return int(np.count_nonzero(first >= fresh))

    def clear(self):
        """Forget every point (safe to call while another thread updates: that update keeps only
        its fresh points)."""
        self.cleared += 1
        self.points, self.seen_at, self.seen_from = np.zeros((0, 3)), np.zeros(0), np.zeros(0)
        self.held = np.zeros(0, dtype=bool)
        self.columns = np.zeros((0, 3))

    def age(self, now):
        """[s] since the last frame."""
        return now - self.stamp
