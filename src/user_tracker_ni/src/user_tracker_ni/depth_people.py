"""People in a Kinect depth image (no ROS; vectorised over pixels).

The camera sits 0.54 m above the floor with a 57 x 43 degree view: a standing person's head is
in view only beyond about 2.9 m, and nearer than about 1.1 m nothing above 0.95 m is. The
detector therefore looks for what every person in view shows and furniture does not:

1. Back-project the (decimated) depth image into the robot's base frame (z up from the floor)
   through the camera's intrinsics and its 4x4 pose.
2. Upper bodies: points between ``upper_min`` (0.95 m, above tables, sofa backs, counters and
   chair backs) and ``max_height``, gridded on the floor plane (``cell``) and split into
   8-connected clusters. Walls, doors and the wardrobe reach this band too.
3. Each cluster is judged on its shape:
   - lateral width (across the line of sight) within ``min_width``..``max_width``: a wall or a
     wardrobe is wider, a wall's end, a lamp's pole or a coat stand's pole narrower;
   - not flat: a torso is round, the spread of its points across the best vertical plane is
     at least ``min_roundness`` plus half the depth noise there; a wall piece or a cupboard
     door is flat;
   - a body below it: the band ``hips_min``..``hips_max`` (legs, hips or a seated torso)
     within ``body_reach`` of the cluster holds at least ``min_hips_width`` of width: the pole
     of a floor lamp, of a coat stand, the trunk of a tall plant do not;
   - it does not touch the left or right border of the image (half a person is placed badly
     and half a wall looks like one): the laser keeps a person there.
4. What passes is a person: its centre is the mean of its upper-body points moved back along
   the line of sight by 3/8 of its width (the camera sees the near side); its top height
   (``truncated`` when the image's top row cuts it), its posture (sitting when its top is seen
   below ``sitting_top``) and a colour signature of its torso (reid.signature) when a
   registered colour image is given.

:func:`detect` returns the people and, for diagnostics, the number of clusters rejected for
each reason.
"""

import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from user_tracker_ni import reid

CENTRE_SHIFT = 0.375  # the body's centre beyond the mean of its visible points, in widths


@dataclass(frozen=True)
class DepthParams:
    target_width: int = 160  # [px] the image is decimated to about this width first
    min_range: float = 0.45  # [m] nearer depth readings are ignored
    max_range: float = 4.5  # [m] farther ones too
    upper_min: float = 0.95  # [m] lowest point of the upper-body band
    max_height: float = 2.1  # [m] highest point considered
    cell: float = 0.06  # [m] floor grid of the clustering
    min_points: int = 12  # upper-body points of a person (decimated image)
    min_width: float = 0.22  # [m] narrowest upper body across the line of sight
    max_width: float = 0.85  # [m] widest
    min_roundness: float = 0.012  # [m] spread across the best vertical plane of a round torso
    noise_at_1m: float = 0.0016  # [m] depth noise standard deviation at 1 m (grows with d^2)
    hips_min: float = 0.55  # [m] the body band below the upper body
    hips_max: float = 0.90  # [m]
    min_hips_width: float = 0.16  # [m]
    body_reach: float = 0.12  # [m] how far around the upper body's footprint the body band is looked for
    sitting_top: float = 1.45  # [m] a person whose top is seen below this is sitting
    border: int = 1  # [px, decimated] clusters touching the left or right border are not judged

    def validate(self):
        for name in ("min_range", "max_range", "cell", "min_width", "max_width", "min_hips_width", "body_reach"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not (self.min_range < self.max_range and self.min_width < self.max_width
                and 0 < self.hips_min < self.hips_max <= self.upper_min < self.max_height):
            raise ValueError("need min_range < max_range, min_width < max_width and "
                             "0 < hips_min < hips_max <= upper_min < max_height")
        if self.target_width < 16 or self.min_points < 3:
            raise ValueError("target_width must be >= 16 and min_points >= 3")
        return self


@dataclass(frozen=True)
class PersonDetection:
    x: float  # [m] centre in the base frame
    y: float  # [m]
    top: float  # [m] highest point seen
    truncated: bool  # the image's top row cut the person: top is a lower bound
    width: float  # [m] across the line of sight
    posture: str  # "standing" or "sitting" ("unknown" when truncated)
    points: int
    signature: np.ndarray | None = None


class Camera:
    """Pinhole intrinsics of the depth image (fx, fy, cx, cy [px]) and its size."""

    def __init__(self, K, width, height):
        fx, _, cx, _, fy, cy = (float(v) for v in list(K)[:6])
        if not (fx > 0 and fy > 0 and width > 0 and height > 0):
            raise ValueError(f"camera_info has no usable intrinsics: K={list(K)}, size {width}x{height}")
        self.fx, self.fy, self.cx, self.cy = fx, fy, cx, cy
        self.width, self.height = int(width), int(height)
        self._rays = {}

    def rays(self, stride):
        """Unit-depth rays [h, w, 3] of the pixels kept at ``stride`` (optical frame), cached."""
        if stride not in self._rays:
            v, u = np.mgrid[0:self.height:stride, 0:self.width:stride].astype(np.float32)
            self._rays[stride] = np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones_like(u)], -1)
        return self._rays[stride]


def stride_for(width, params):
    return max(1, round(width / params.target_width))


def detect(depth, camera, camera_pose, params, rgb=None):
    """(people, rejected) of one depth image.

    depth: [H, W] float [m], NaN (or 0) for no return; camera: :class:`Camera`; camera_pose:
    4x4 pose of the optical frame in the base frame (z up from the floor); rgb: optional
    [H', W', 3] uint8 colour image registered to the depth image (resized if its size differs).
    rejected: Counter of the reasons clusters were not people."""
    p = params
    depth = np.asarray(depth)
    if depth.shape != (camera.height, camera.width):
        raise ValueError(f"depth image {depth.shape[1]}x{depth.shape[0]} does not match its camera_info "
                         f"{camera.width}x{camera.height}")
    stride = stride_for(camera.width, p)
    d = depth[::stride, ::stride].astype(np.float32)
    rays = camera.rays(stride)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(d) & (d > p.min_range) & (d < p.max_range)
    R, t = np.asarray(camera_pose)[:3, :3], np.asarray(camera_pose)[:3, 3]
    vv, uu = np.nonzero(valid)
    pts = (rays[vv, uu] * d[vv, uu, None]) @ R.T.astype(np.float32) + t.astype(np.float32)
    z = pts[:, 2]
    upper = (z >= p.upper_min) & (z <= p.max_height)
    hips = (z >= p.hips_min) & (z <= p.hips_max)
    rejected = Counter()
    if np.count_nonzero(upper) < p.min_points:
        return [], rejected

    # grid the floor plane around what is in view
    lo = pts[upper | hips, :2].min(axis=0) - p.body_reach - p.cell
    cells = np.floor((pts[:, :2] - lo) / p.cell).astype(np.int64)
    shape = tuple(int(v) for v in cells[upper | hips].max(axis=0) + math.ceil(p.body_reach / p.cell) + 2)
    grid = np.zeros(shape, bool)
    grid[cells[upper, 0], cells[upper, 1]] = True
    labels, n = ndimage.label(grid, structure=np.ones((3, 3), bool))
    point_label = np.where(upper, labels[cells[:, 0].clip(0, shape[0] - 1), cells[:, 1].clip(0, shape[1] - 1)], 0)
    reach = math.ceil(p.body_reach / p.cell)
    near = ndimage.grey_dilation(labels, size=(2 * reach + 1, 2 * reach + 1))
    hips_label = np.where(hips, near[cells[:, 0].clip(0, shape[0] - 1), cells[:, 1].clip(0, shape[1] - 1)], 0)

    cam_xy = t[:2]
    rel = pts[:, :2] - cam_xy
    rng = np.hypot(rel[:, 0], rel[:, 1])
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    w_img = d.shape[1]
    colour = None if rgb is None else _registered(rgb, depth.shape, stride, d.shape)
    people = []
    for label in range(1, n + 1):
        mine = point_label == label
        count = int(np.count_nonzero(mine))
        if count < p.min_points:
            rejected["few points"] += 1
            continue
        cols = uu[mine]
        if cols.min() < p.border or cols.max() >= w_img - p.border:
            rejected["at the image border"] += 1
            continue
        r_mean = float(rng[mine].mean())
        width = _lateral_width(bearing[mine], r_mean)
        if not p.min_width <= width <= p.max_width:
            rejected["too narrow" if width < p.min_width else "too wide"] += 1
            continue
        noise = p.noise_at_1m * r_mean * r_mean
        if _roundness(pts[mine, :2]) < p.min_roundness + 0.5 * noise:
            rejected["flat"] += 1
            continue
        body = hips_label == label
        hips_width = _lateral_width(bearing[body], r_mean) if np.count_nonzero(body) >= 3 else 0.0
        if hips_width < p.min_hips_width:
            rejected["no body below"] += 1
            continue
        top = float(z[mine].max())
        truncated = bool(vv[mine].min() <= 0)
        centroid = pts[mine, :2].mean(axis=0)
        ray = (centroid - cam_xy) / max(float(np.hypot(*(centroid - cam_xy))), 1e-6)
        centre = centroid + ray * CENTRE_SHIFT * width
        posture = "unknown" if truncated else ("sitting" if top < p.sitting_top else "standing")
        sig = None
        if colour is not None:
            band = _torso_band(top, truncated, p)
            torso = mine | (hips_label == label)
            torso &= (z >= band[0]) & (z <= band[1])
            if np.count_nonzero(torso) >= p.min_points:
                sig = reid.signature(colour[vv[torso], uu[torso]])
        people.append(PersonDetection(float(centre[0]), float(centre[1]), top, truncated, width, posture, count, sig))
    return people, rejected


def _lateral_width(bearings, distance):
    """Width [m] across the line of sight of points at these bearings [rad] (2nd..98th
    percentile, so a stray point does not widen it), at ``distance`` [m]."""
    if len(bearings) < 2:
        return 0.0
    lo, hi = np.percentile(bearings, [2, 98])
    return float((hi - lo) * distance)


def _roundness(xy):
    """Standard deviation [m] of the points across their best-fitting line (the smaller
    principal axis): about zero for a flat face seen from anywhere, several cm for a torso."""
    if len(xy) < 3:
        return 0.0
    c = np.cov(xy.T.astype(np.float64))
    return float(math.sqrt(max(np.linalg.eigvalsh(c)[0], 0.0)))


def _torso_band(top, truncated, p):
    """Heights [m] of the shirt: below the head when the top is seen, the middle of the upper
    body band otherwise."""
    if truncated:
        return p.hips_max, min(top, 1.45)
    return max(p.hips_min, top - 0.75), top - 0.3


def _registered(rgb, depth_shape, stride, small_shape):
    """The colour image at the decimated depth pixels (a registered image of another size is
    resized to the depth image's first)."""
    import cv2

    rgb = np.asarray(rgb)
    if rgb.shape[:2] != depth_shape:
        rgb = cv2.resize(rgb, (depth_shape[1], depth_shape[0]), interpolation=cv2.INTER_NEAREST)
    return rgb[::stride, ::stride][: small_shape[0], : small_shape[1]]
