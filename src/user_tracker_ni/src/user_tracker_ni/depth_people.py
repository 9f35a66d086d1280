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
   - not taller than a person: no point within 5 cm of ``max_height`` (a wall's end, a door
     frame, a wardrobe reach it, also where the image's top row cuts them);
   - not deep: along the line of sight its points span at most ``max_depth`` (plus the depth
     noise): the camera sees a body's near side only, a wall seen at a grazing angle runs away
     from the camera for metres;
   - not flat: a torso is round, the spread of its points across the best vertical plane is
     at least ``min_roundness`` plus half the depth noise there; a wall piece or a cupboard
     door is flat;
   - not hollow: a torso bulges toward the camera (its range, as a function of the bearing, is
     convex); the inside corner of two walls is hollow;
   - a body below it: in the image, the pixels under the middle half of the cluster's columns
     that would show heights ``fill_min``..``fill_max`` (0.40-0.75 m: legs, hips or a seated
     torso) at the cluster's distance mostly show something at that distance (within
     ``fill_tolerance``) rather than the background through it: the pole of a floor lamp or of
     a coat stand, the trunk of a tall plant leave the background visible there. At least
     ``min_fill`` of those pixels must be body; pixels showing something nearer (a table, a
     sofa's back in front of the person) are occluded and do not count, and when fewer than
     ``min_judged`` of the pixels can be judged (occluded, or out of the image) the cluster is not
     rejected for it;
   - it does not touch the left or right border of the image (half a person is placed badly
     and half a wall looks like one): the laser keeps a person there.
4. What passes is a person: its centre is the mean of its upper-body points moved back along
   the line of sight by 3/8 of its width (the camera sees the near side); its top height
   (``truncated`` when the image's top row cuts it), its posture (sitting when its top is seen
   below ``sitting_top``) and a colour signature of its torso (reid.signature) when a
   registered colour image is given.
5. Which way a seated person faces: a seated body's knees and lower legs stand in front of its
   torso (0.3-0.5 m for an adult on a chair or a sofa). The mean of the points at the height of
   the shins (``legs_min``..``legs_max``) within ``facing_reach`` of the torso, in patches that come
   within ``facing_gap`` of its centre (the legs of a chair or a table 0.4-0.6 m away turned the
   facing 16-55 deg, or hid it, in a synthetic scene; the living room's dining chair 0.54 m from the
   day's seat turned it 25 deg in florence_sim), less the mean of the upper-body points, points the
   way the person faces: both means are of near sides seen from one camera.
   Whether the shins stand out from the torso at all is told from their centres, not their near
   sides: a leg is narrower than a torso, so its near side lies nearer its centre, and a standing
   person's legs under her torso read as shins 0.09-0.10 m beyond it, away from the camera
   (standing people were given facings away from the camera, about along its line of sight, at
   1.2-2.8 m, where the image cuts their heads off and the posture is unknown; bench/locator.py's
   approach_me_map went round to their backs). So each run of image columns among the shin points
   (split where more than ``FACING_COLUMN_GAP`` columns show none: one leg, both side by side, a
   seated body's thighs and shins) is moved back along the line of sight by 3/8 of its own width,
   as the torso is (4.), and when the mean of that lies less than ``facing_min_offset`` from the
   torso's centre, ``facing`` stays None (a standing person's legs: 0.035 m at most in the
   synthetic scenes at 1.5-3.2 m, against at least 0.11 m for a seated person's shins from any
   side; a seat or a table hiding them, or legs tucked under). Its direction is not the facing:
   seen from the side, one shin hides the other and the centre of the near one alone turned the
   facing up to 30 deg toward the camera. A person seen standing gets no facing either.

6. Close up, where none of this can work (nearer than about 1.1 m nothing above ``upper_min`` is in
   view), :func:`close_sightings` reports what stands where a tracked person is expected, with its
   colours, for the tracker to keep that person by (pipeline.py): never a new person.

:func:`detect` returns the people and, for diagnostics, the number of clusters rejected for
each reason.
"""

import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from florence_common.camera import stride_for
from user_tracker_ni import reid

CENTRE_SHIFT = 0.375  # the body's centre beyond the mean of its visible points, in widths
FACING_CELL = 0.05  # [m] grid on which the points at shin height connect into patches (legs, a chair's leg)
FACING_COLUMN_GAP = 2  # [px, decimated] shin points this many empty columns apart are two legs (a standing
#                        person's, 0.07 m apart: 2.5 columns at 3 m)
TALL_MARGIN = 0.05  # [m] points this near max_height: taller than people (a door frame, a wall)


@dataclass(frozen=True)
class DepthParams:
    target_width: int = 160  # [px] the image is decimated to about this width first
    min_range: float = 0.45  # [m] nearer depth readings are ignored
    max_range: float = 4.5  # [m] farther ones too
    upper_min: float = 0.95  # [m] lowest point of the upper-body band
    max_height: float = 2.15  # [m] highest point considered; a cluster reaching it is taller than a person
    cell: float = 0.06  # [m] floor grid of the clustering
    min_points: int = 12  # upper-body points of a person (decimated image)
    min_width: float = 0.22  # [m] narrowest upper body across the line of sight
    max_width: float = 0.85  # [m] widest
    max_depth: float = 0.5  # [m] extent of its points along the line of sight
    min_roundness: float = 0.012  # [m] spread across the best vertical plane of a round torso
    noise_at_1m: float = 0.0016  # [m] depth noise standard deviation at 1 m (grows with d^2)
    hips_min: float = 0.55  # [m] the band below the upper body whose colours count as the shirt's
    hips_max: float = 0.90  # [m]   when the image cuts the top (a near person)
    body_reach: float = 0.12  # [m] how far around the upper body's footprint that band is looked for
    fill_min: float = 0.40  # [m] heights below the upper body where a person shows a body ...
    fill_max: float = 0.75  # [m]
    min_fill: float = 0.35  # ... in at least this share of the judged pixels
    fill_tolerance: float = 0.30  # [m] a pixel within this of the cluster's distance is body
    min_judged: float = 0.3  # share of those pixels that must be judgeable (not occluded, in the image)
    sitting_top: float = 1.45  # [m] a person whose top is seen below this is sitting
    border: int = 1  # [px, decimated] clusters touching the left or right border are not judged
    legs_min: float = 0.08  # [m] heights of a seated person's shins (the facing cue) ...
    legs_max: float = 0.42  # [m]
    facing_reach: float = 0.6  # [m] ... looked for this near the upper body's centre ...
    facing_gap: float = 0.3  # [m] ... in patches (connected on a 5 cm grid) that come this near it: not a chair's leg
    facing_min_offset: float = 0.08  # [m] shins whose centre is this far from the torso's tell the facing
    close_range: float = 1.4  # [m] a tracked person nearer the camera than this is looked for close up (0: never)
    close_min: float = 0.55  # [m] lowest point of a body seen close up (close_sightings; up to upper_min)
    close_radius: float = 0.35  # [m] how near the expected place its points lie
    close_depth: float = 0.3  # [m] and how far behind the nearest of them along the line of sight
    close_gate: float = 0.4  # largest colour difference (Bhattacharyya) of what is seen there and the person
    occluder_margin: float = 0.3  # [m] something this much nearer than a person just beside them in the image ...
    occluder_reach: int = 3  # [px, decimated] ... within this many pixels of their outline (the Kinect's edge gaps) ...
    occluded_share: float = 0.3  # ... along at least this share of their rows on one side: they are partly hidden

    def validate(self):
        for name in ("min_range", "max_range", "cell", "min_width", "max_width", "max_depth", "body_reach",
                     "fill_tolerance"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not (self.min_range < self.max_range and self.min_width < self.max_width
                and 0 < self.hips_min < self.hips_max <= self.upper_min < self.max_height):
            raise ValueError("need min_range < max_range, min_width < max_width and "
                             "0 < hips_min < hips_max <= upper_min < max_height")
        if not (0 <= self.legs_min < self.legs_max <= self.hips_max and self.facing_reach > 0
                and 0 < self.facing_min_offset < self.facing_reach and 0 < self.facing_gap <= self.facing_reach):
            raise ValueError("need 0 <= legs_min < legs_max <= hips_max, facing_reach > 0, "
                             "0 < facing_min_offset < facing_reach and 0 < facing_gap <= facing_reach")
        if self.close_range < 0 or not (0 < self.close_min < self.upper_min and self.close_radius > 0
                                        and self.close_depth > 0 and 0 < self.close_gate <= 1):
            raise ValueError("need close_range >= 0, 0 < close_min < upper_min, close_radius > 0, close_depth > 0 "
                             "and 0 < close_gate <= 1")
        if self.occluder_margin <= 0 or self.occluder_reach < 1 or not 0 < self.occluded_share <= 1:
            raise ValueError("need occluder_margin > 0, occluder_reach >= 1 and 0 < occluded_share <= 1")
        if self.target_width < 16 or self.min_points < 3:
            raise ValueError("target_width must be >= 16 and min_points >= 3")
        if not (0 <= self.fill_min < self.fill_max <= self.upper_min and 0 <= self.min_fill <= 1
                and 0 <= self.min_judged <= 1):
            raise ValueError("need 0 <= fill_min < fill_max <= upper_min, min_fill and min_judged within 0..1")
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
    facing: float | None = None  # [rad] in the base frame, a seated person's (module docstring, 5); None: unknown
    occluded: bool = False  # partly hidden behind something nearer beside them in the image: the centre is off


def detect(depth, camera, camera_pose, params, rgb=None):
    """(people, rejected) of one depth image.

    depth: [H, W] float [m], NaN (or 0) for no return; camera: :class:`florence_common.camera.Camera`; camera_pose:
    4x4 pose of the optical frame in the base frame (z up from the floor); rgb: optional
    [H', W', 3] uint8 colour image registered to the depth image (resized if its size differs).
    rejected: Counter of the reasons clusters were not people."""
    p = params
    d, rays, R, t, vv, uu, pts = _cloud(depth, camera, camera_pose, p)
    stride = stride_for(camera.width, p.target_width)
    z = pts[:, 2]
    upper = (z >= p.upper_min) & (z <= p.max_height)
    hips = (z >= p.hips_min) & (z <= p.hips_max)
    shins = (z >= p.legs_min) & (z <= p.legs_max)
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
    colour = None if rgb is None else _registered(rgb, np.shape(depth), stride, d.shape)
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
        top = float(z[mine].max())
        truncated = bool(vv[mine].min() <= 0)
        if top >= p.max_height - TALL_MARGIN:
            rejected["taller than a person"] += 1
            continue
        near, far = np.percentile(rng[mine], [2, 98])
        if far - near > p.max_depth + 2 * noise:
            rejected["too deep"] += 1
            continue
        if _roundness(pts[mine, :2]) < p.min_roundness + 0.5 * noise:
            rejected["flat"] += 1
            continue
        if _curvature(bearing[mine], rng[mine]) < 0:
            rejected["hollow (a corner of walls)"] += 1
            continue
        if _fill_below(d, rays, R, t, bearing[mine], r_mean, p) < p.min_fill:
            rejected["no body below"] += 1
            continue
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
        facing = None if posture == "standing" else _facing(pts[shins, :2], uu[shins], cam_xy, centroid, centre,
                                                             stride / camera.fx, p)
        occluded = _occluded(d, vv[mine], uu[mine], p)
        people.append(PersonDetection(float(centre[0]), float(centre[1]), top, truncated, width, posture, count, sig,
                                      facing, occluded))
    return people, rejected


@dataclass(frozen=True)
class CloseSighting:
    """A body seen close up where a person was expected (:func:`close_sightings`)."""

    x: float  # [m] centre in the base frame
    y: float  # [m]
    width: float  # [m] across the line of sight
    points: int
    signature: np.ndarray  # colour signature (reid.signature) of the points


def close_sightings(depth, camera, camera_pose, points, rgb, params):
    """What the Kinect shows, close up, where people are expected: for each of ``points`` [N, 2]
    (base frame: a tracked person's predicted place) a :class:`CloseSighting` or None.

    Nearer than about 1.1 m the image shows nothing above 0.95 m (module docstring), so
    :func:`detect` cannot see a person there; a seated one also shows the laser no legs (their
    shins are one wide block). Below the upper-body band a person is indistinguishable from
    furniture by shape, so this only looks where a tracked person is expected and reports what is
    there with its colours, for the caller to compare with that person's: the points between
    ``close_min`` and ``upper_min`` within ``close_radius`` of the place, keeping the near side
    (within ``close_depth`` of the nearest of them along the line of sight: not the wall behind),
    at least ``min_points`` of them and ``min_width``..``max_width`` wide. The centre is their
    mean moved back along the line of sight as :func:`detect` does. None without a colour image
    (the colours are the only check of who it is) or where too little is seen."""
    p = params
    pts_in = np.asarray(points, float).reshape(-1, 2)
    out = [None] * len(pts_in)
    if rgb is None or len(pts_in) == 0:
        return out
    d, _, _, t, vv, uu, pts = _cloud(depth, camera, camera_pose, p)
    band = (pts[:, 2] >= p.close_min) & (pts[:, 2] < p.upper_min)
    if np.count_nonzero(band) < p.min_points:
        return out
    colour = _registered(rgb, np.shape(depth), stride_for(camera.width, p.target_width), d.shape)
    pts, vv, uu = pts[band], vv[band], uu[band]
    rel = pts[:, :2] - t[:2]
    rng = np.hypot(rel[:, 0], rel[:, 1])
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    for k, (x, y) in enumerate(pts_in):
        mine = np.hypot(pts[:, 0] - x, pts[:, 1] - y) <= p.close_radius
        if np.count_nonzero(mine) < p.min_points:
            continue
        mine &= rng <= np.percentile(rng[mine], 2) + p.close_depth
        count = int(np.count_nonzero(mine))
        if count < p.min_points:
            continue
        width = _lateral_width(bearing[mine], float(rng[mine].mean()))
        if not p.min_width <= width <= p.max_width:
            continue
        centroid = pts[mine, :2].mean(axis=0)
        ray = (centroid - t[:2]) / max(float(np.hypot(*(centroid - t[:2]))), 1e-6)
        centre = centroid + ray * CENTRE_SHIFT * width
        out[k] = CloseSighting(float(centre[0]), float(centre[1]), width, count,
                               reid.signature(colour[vv[mine], uu[mine]]))
    return out


def in_clear_view(depth, camera, camera_pose, points, params, height=1.1, margin=0.12, clearance=0.3,
                  beyond=-0.5, any_height=False):
    """Boolean [N]: the camera would see the upper body of a person standing or sitting at each of
    ``points`` [N, 2] (base frame): the point ``height`` [m] above the floor projects inside the
    image (``margin``: share of the width kept free at either side, where the detector does not
    judge), in range, and the depth image shows nothing nearer than it by ``clearance`` [m] there
    (no occluder). In range: from ``min_range + clearance`` to ``max_range + beyond`` (the default
    keeps half a metre inside the far limit, where the detector is sure to see a person).
    ``any_height``: in front of the camera whatever the height (a person too near for the image
    to show the upper body, who will show it on stepping back), judged at the image's nearest row.
    depth: [H, W] [m] (NaN for no return); camera: :class:`florence_common.camera.Camera`; camera_pose: 4x4 pose of the
    optical frame in the base frame."""
    pts = np.asarray(points, float).reshape(-1, 2)
    if len(pts) == 0:
        return np.zeros(0, bool)
    pose = np.asarray(camera_pose, float)
    world = np.column_stack([pts, np.full(len(pts), height)])
    optical = (world - pose[:3, 3]) @ pose[:3, :3]  # base -> optical frame (R^T (p - t))
    z = optical[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = camera.fx * optical[:, 0] / z + camera.cx
        v = camera.fy * optical[:, 1] / z + camera.cy
    lo_u, hi_u = margin * camera.width, (1 - margin) * camera.width - 1
    ok = (z > params.min_range + clearance) & (z < params.max_range + beyond)
    ok &= (u >= lo_u) & (u <= hi_u)
    if not any_height:
        ok &= (v >= 0) & (v <= camera.height - 1)
    out = np.zeros(len(pts), bool)
    d = np.asarray(depth)
    for k in np.flatnonzero(ok):  # a handful of tracks: a 5 x 5 patch each
        ui, vi = round(float(u[k])), min(max(round(float(v[k])), 0), camera.height - 1)
        patch = d[max(vi - 2, 0):vi + 3, max(ui - 2, 0):ui + 3]
        with np.errstate(invalid="ignore"):
            nearer = np.count_nonzero(patch < z[k] - clearance)
        out[k] = nearer <= patch.size // 4
    return out


def _occluded(d, rows, cols, p):
    """Whether the person whose pixels of the decimated depth image ``d`` are (rows, cols) is partly
    hidden: beyond their outline on the left or the right, within ``occluder_reach`` pixels,
    something at least ``occluder_margin`` nearer than the nearest of them (the 2nd percentile of
    their depths), along ``occluded_share`` of their rows. What is seen of them is then the side
    that is not hidden, and its centroid lies off their centre."""
    near = float(np.percentile(d[rows, cols], 2))
    top, width = int(rows.min()), d.shape[1]
    height = int(rows.max()) - top + 1
    left = np.full(height, width, np.int64)
    right = np.full(height, -1, np.int64)
    np.minimum.at(left, rows - top, cols)
    np.maximum.at(right, rows - top, cols)
    seen = right >= 0
    r = np.nonzero(seen)[0] + top
    offsets = np.arange(1, p.occluder_reach + 1)
    limit = near - p.occluder_margin
    for edge, sign in ((left[seen], -1), (right[seen], 1)):
        c = edge[:, None] + sign * offsets[None, :]
        inside = (c >= 0) & (c < width)
        vals = np.where(inside, d[r[:, None], c.clip(0, width - 1)], np.nan)
        with np.errstate(invalid="ignore"):
            nearer = np.any(vals < limit, axis=1)
        if np.count_nonzero(nearer) >= p.occluded_share * len(r):
            return True
    return False


def _cloud(depth, camera, camera_pose, p):
    """The decimated depth image back-projected: (d [h, w] m, rays [h, w, 3] at unit optical
    depth, R, t (the optical frame's rotation and position in the base frame), vv, uu (pixel rows
    and columns of the valid readings), points [N, 3] in the base frame). ValueError for an image
    that does not match its camera."""
    depth = np.asarray(depth)
    if depth.shape != (camera.height, camera.width):
        raise ValueError(f"depth image {depth.shape[1]}x{depth.shape[0]} does not match its camera_info "
                         f"{camera.width}x{camera.height}")
    stride = stride_for(camera.width, p.target_width)
    d = depth[::stride, ::stride].astype(np.float32)
    rays = camera.rays(stride, np.float32)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(d) & (d > p.min_range) & (d < p.max_range)
    R, t = np.asarray(camera_pose)[:3, :3], np.asarray(camera_pose)[:3, 3]
    vv, uu = np.nonzero(valid)
    pts = (rays[vv, uu] * d[vv, uu, None]) @ R.T.astype(np.float32) + t.astype(np.float32)
    return d, rays, R, t, vv, uu, pts


def _fill_below(d, rays, R, t, bearings, distance, p):
    """Share of the judgeable pixels below a cluster that show a body (see the module's docstring);
    1.0 when too few can be judged. d: decimated depth [m]; rays: its unit-depth rays (optical);
    R, t: the optical frame's pose in the base frame; bearings: of the cluster's points from the
    camera [rad]; distance: its mean horizontal range from the camera [m]."""
    lo, hi = np.percentile(bearings, [2, 98])
    mid, quarter = (lo + hi) / 2, (hi - lo) / 4
    middle_row = rays[rays.shape[0] // 2] @ R.T.astype(np.float32)
    column_bearing = np.arctan2(middle_row[:, 1], middle_row[:, 0])
    columns = np.flatnonzero(np.abs(column_bearing - mid) <= quarter)
    if len(columns) == 0:
        return 1.0
    u0, u1 = int(columns[0]), int(columns[-1]) + 1
    window_rays = rays[:, u0:u1] @ R.T.astype(np.float32)  # base-frame directions [h, w, 3]
    horiz = np.hypot(window_rays[..., 0], window_rays[..., 1])
    scale = distance / np.maximum(horiz, 1e-6)  # ray length (at unit optical depth) to that range
    z = t[2] + window_rays[..., 2] * scale  # height each pixel would show at the cluster's distance
    band = (z >= p.fill_min) & (z <= p.fill_max)
    expected = round((p.fill_max - p.fill_min) / max(float(np.median(np.abs(np.diff(z, axis=0)))), 1e-6))
    depth = d[:, u0:u1]
    seen_range = depth * horiz  # horizontal range of what each pixel shows
    with np.errstate(invalid="ignore"):
        body = band & (np.abs(seen_range - distance) <= p.fill_tolerance)
        through = band & ~(seen_range < distance - p.fill_tolerance) & ~body  # farther, or nothing (NaN)
    judged = np.count_nonzero(body) + np.count_nonzero(through)
    if judged < p.min_judged * max(expected, 1) * (u1 - u0):
        return 1.0
    return np.count_nonzero(body) / judged


def _curvature(bearings, ranges):
    """Second-order coefficient [m/rad^2] of the range as a function of the bearing (least squares):
    positive for a body that bulges toward the camera (a torso, a wall seen square on: a little),
    negative for a hollow one (the inside corner of two walls)."""
    if len(bearings) < 6:
        return 0.0
    b = bearings - bearings.mean()
    return float(np.polyfit(b.astype(np.float64), ranges.astype(np.float64), 2)[0])


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


def _facing(shins, columns, cam_xy, upper_mean, centre, column_angle, p):
    """Which way [rad] a seated person faces from the points at shin height [N, 2] (all of the image's),
    their decimated image columns [N], the camera's place [2], the mean of the upper-body points,
    the person's centre and the angle [rad] one decimated column spans (module docstring, 5); None
    when it cannot be told."""
    d = np.hypot(shins[:, 0] - centre[0], shins[:, 1] - centre[1])
    keep = d <= p.facing_reach
    near, columns, d = shins[keep], columns[keep], d[keep]
    if len(near) < p.min_points:
        return None
    # the patches of her own legs, not a chair's or a table's legs beside her (8-connected 5 cm cells)
    ij = np.floor((near - near.min(axis=0)) / FACING_CELL).astype(int)
    occupied = np.zeros(ij.max(axis=0) + 1, dtype=bool)
    occupied[ij[:, 0], ij[:, 1]] = True
    labels = ndimage.label(occupied, structure=np.ones((3, 3), dtype=bool))[0][ij[:, 0], ij[:, 1]]
    mine = np.isin(labels, np.unique(labels[d <= p.facing_gap]))
    near, columns = near[mine], columns[mine]
    if len(near) < p.min_points:
        return None
    stand_out = _leg_centre(near, columns, cam_xy, column_angle) - centre
    if float(np.hypot(*stand_out)) < p.facing_min_offset:
        return None
    offset = near.mean(axis=0) - upper_mean
    return float(math.atan2(offset[1], offset[0]))


def _leg_centre(points, columns, cam_xy, column_angle):
    """The mean [2] of ``points`` [N, 2] (near sides seen from ``cam_xy``), each run of image
    ``columns`` among them moved back along its line of sight by CENTRE_SHIFT of its width (module
    docstring, 5)."""
    cols = np.unique(columns)
    starts = cols[np.r_[True, np.diff(cols) > FACING_COLUMN_GAP]]
    run = np.searchsorted(starts, columns, side="right")
    rel = points - cam_xy
    out = points.astype(np.float64)
    for k in np.unique(run):  # a few runs (legs) per person
        mine = run == k
        span = int(columns[mine].max() - columns[mine].min()) + 1
        # back along the run's line of sight by CENTRE_SHIFT x its width (its range x span x column_angle)
        out[mine] += rel[mine].mean(axis=0) * (CENTRE_SHIFT * span * column_angle)
    return out.mean(axis=0)


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
