"""2.5D scene geometry and ray casting (numpy, and numba for the camera's rays; no ROS).

A scene is a set of vertical prisms standing on the floor (z up, REP 103):

- boxes: rectangles in the floor plane (centre, yaw, half sizes) extruded from
  ``z0`` to ``z1`` [m];
- cylinders: circles (centre, radius) extruded from ``z0`` to ``z1`` [m];
- the floor ``z = 0`` and optionally a ceiling.

Walls, furniture parts and the parts of people are all boxes or cylinders, so one
ray caster serves the laser (2D rays in a horizontal plane) and the Kinect (3D
rays). Every function works on whole arrays of rays at once; the camera's many rays against
the primitives near each image column go through one compiled loop (:func:`_first_hits`: numpy's
ray-by-primitive arrays cost the simulator a sixth of a core at 15 frames a second).
"""

from dataclasses import dataclass, field

import numpy as np

from florence_common.angles import wrap
from florence_common.jit import lazy_njit

BIG = np.float32(1e9)


@dataclass
class Box:
    """A box standing upright: centre ``(x, y)`` [m], ``yaw`` [rad], size ``(sx, sy)`` [m], heights ``z0..z1`` [m]."""

    name: str
    x: float
    y: float
    yaw: float
    sx: float
    sy: float
    z0: float
    z1: float
    color: tuple = (0.7, 0.7, 0.7)  # RGB 0..1

    def corners(self):
        """The four floor-plan corners, counter-clockwise, shape (4, 2) [m]."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        hx, hy = self.sx / 2.0, self.sy / 2.0
        local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
        return local @ np.array([[c, s], [-s, c]]) + [self.x, self.y]


@dataclass
class Cylinder:
    """A vertical cylinder: centre ``(x, y)`` [m], ``radius`` [m], heights ``z0..z1`` [m]."""

    name: str
    x: float
    y: float
    radius: float
    z0: float
    z1: float
    color: tuple = (0.7, 0.7, 0.7)


@dataclass
class Scene:
    """Array form of a list of boxes and cylinders, ready for ray casting.

    Boxes become their four vertical faces (segments with an outward normal) and
    their horizontal caps; cylinders stay cylinders. ``names[i]`` names primitive
    ``i`` (boxes first, then cylinders) for error messages and hit reports.
    """

    boxes: list = field(default_factory=list)
    cylinders: list = field(default_factory=list)
    ceiling: float = 0.0  # [m] height of the ceiling plane, 0 for none

    def __post_init__(self):
        nb, nc = len(self.boxes), len(self.cylinders)
        self.names = [b.name for b in self.boxes] + [c.name for c in self.cylinders]
        colors = [b.color for b in self.boxes] + [c.color for c in self.cylinders]
        self.colors = np.array(colors, dtype=np.float32).reshape(-1, 3)
        # boxes
        self.box_center = np.array([[b.x, b.y] for b in self.boxes], dtype=float).reshape(nb, 2)
        self.box_yaw = np.array([b.yaw for b in self.boxes], dtype=float)
        self.box_half = np.array([[b.sx / 2, b.sy / 2] for b in self.boxes], dtype=float).reshape(nb, 2)
        self.box_z = np.array([[b.z0, b.z1] for b in self.boxes], dtype=float).reshape(nb, 2)
        corners = np.array([b.corners() for b in self.boxes], dtype=float).reshape(nb, 4, 2)
        # faces: segment a -> b, counter-clockwise, so the outward normal is (dy, -dx)
        self.face_a = corners.reshape(-1, 2)
        self.face_b = np.roll(corners, -1, axis=1).reshape(-1, 2)
        self.face_owner = np.repeat(np.arange(nb), 4)
        self.face_z = np.repeat(self.box_z, 4, axis=0)
        # cylinders
        self.cyl_center = np.array([[c.x, c.y] for c in self.cylinders], dtype=float).reshape(nc, 2)
        self.cyl_radius = np.array([c.radius for c in self.cylinders], dtype=float)
        self.cyl_z = np.array([[c.z0, c.z1] for c in self.cylinders], dtype=float).reshape(nc, 2)
        self.cyl_owner = nb + np.arange(nc)

    def with_cylinders(self, cylinders):
        """This scene plus extra ``cylinders`` (e.g. people), without rebuilding the static arrays."""
        out = object.__new__(Scene)
        out.__dict__.update(self.__dict__)
        if not cylinders:
            return out
        out.cylinders = self.cylinders + list(cylinders)
        out.names = self.names + [c.name for c in cylinders]
        out.colors = np.concatenate([self.colors, np.array([c.color for c in cylinders], dtype=np.float32)])
        out.cyl_center = np.concatenate([self.cyl_center, [[c.x, c.y] for c in cylinders]])
        out.cyl_radius = np.concatenate([self.cyl_radius, [c.radius for c in cylinders]])
        out.cyl_z = np.concatenate([self.cyl_z, [[c.z0, c.z1] for c in cylinders]])
        out.cyl_owner = np.concatenate([self.cyl_owner, len(self.names) + np.arange(len(cylinders))])
        return out

    # ------------------------------------------------------------------ 2D queries
    def clearance(self, points, z_max, z_min=0.0):
        """Distance [m] from each point (N, 2) to the nearest footprint of a primitive
        that overlaps heights ``z_min..z_max`` (negative inside); also its index.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        best = np.full(len(points), np.inf)
        owner = np.full(len(points), -1)
        boxes = (self.box_z[:, 0] < z_max) & (self.box_z[:, 1] > z_min)
        if boxes.any():
            idx = np.nonzero(boxes)[0]
            d = points[:, None, :] - self.box_center[idx][None]
            c, s = np.cos(self.box_yaw[idx]), np.sin(self.box_yaw[idx])
            lx = d[..., 0] * c + d[..., 1] * s
            ly = -d[..., 0] * s + d[..., 1] * c
            qx = np.abs(lx) - self.box_half[idx, 0]
            qy = np.abs(ly) - self.box_half[idx, 1]
            outside = np.hypot(np.maximum(qx, 0), np.maximum(qy, 0))
            inside = np.minimum(np.maximum(qx, qy), 0)
            dist = outside + inside
            k = np.argmin(dist, axis=1)
            best = dist[np.arange(len(points)), k]
            owner = idx[k]
        cyls = (self.cyl_z[:, 0] < z_max) & (self.cyl_z[:, 1] > z_min)
        if cyls.any():
            idx = np.nonzero(cyls)[0]
            dist = np.linalg.norm(points[:, None, :] - self.cyl_center[idx][None], axis=2) - self.cyl_radius[idx]
            k = np.argmin(dist, axis=1)
            dc = dist[np.arange(len(points)), k]
            closer = dc < best
            best = np.where(closer, dc, best)
            owner = np.where(closer, self.cyl_owner[idx[k]], owner)
        return best, owner

    def cast_2d(self, origin, directions, height, max_range):
        """Ranges [m] along unit ``directions`` (N, 2) from ``origin`` (x, y) in the plane
        ``z = height``; ``inf`` where nothing lies within ``max_range``. Also the hit
        primitive index (-1 for none).
        """
        origin = np.asarray(origin, dtype=float)
        dirs = np.asarray(directions, dtype=float)
        n = len(dirs)
        best = np.full(n, np.inf)
        owner = np.full(n, -1)
        faces = self._faces_near(origin, height, height, max_range)
        if len(faces):
            t, ok = _ray_segments(origin, dirs, self.face_a[faces], self.face_b[faces])
            t = np.where(ok, t, np.inf)
            k = np.argmin(t, axis=1)
            best = t[np.arange(n), k]
            owner = np.where(np.isfinite(best), self.face_owner[faces][k], -1)
        cyls = self._cylinders_near(origin, height, height, max_range)
        if len(cyls):
            t = _ray_circles(origin, dirs, self.cyl_center[cyls], self.cyl_radius[cyls])
            k = np.argmin(t, axis=1)
            tc = t[np.arange(n), k]
            closer = tc < best
            best = np.where(closer, tc, best)
            owner = np.where(closer, self.cyl_owner[cyls][k], owner)
        far = best > max_range
        best[far] = np.inf
        owner[far] = -1
        return best, owner

    # ------------------------------------------------------------------ 3D queries
    def cast_3d(self, origin, directions, max_range, groups=None, heading=None, ray_angles=None):
        """Ray parameter ``t`` of the first hit of each ray ``origin + t * d`` (d: (N, 3),
        need not be unit length) and the hit primitive index (-1 none, -2 floor, -3
        ceiling). ``t`` is ``inf`` without a hit or beyond ``max_range`` in ``t``'s unit
        (pass directions whose relevant component is 1 to get depth directly).

        ``groups`` (list of slices or index arrays into the rays, e.g. image column
        strips) lets each group test only the primitives inside its own horizontal angle
        interval. A caller that knows them may pass the reference ``heading`` [rad] and
        the rays' horizontal angles relative to it (``ray_angles``), or per-group
        ``(lo, hi)`` bounds as ``ray_angles`` (a list as long as ``groups``).
        """
        o = np.asarray(origin, dtype=np.float32)
        d = np.asarray(directions, dtype=np.float32)
        n = len(d)
        best = np.full(n, BIG, dtype=np.float32)
        owner = np.full(n, -1, dtype=np.int32)
        if n == 0:
            return best, owner
        dxy_len = np.hypot(d[:, 0], d[:, 1])
        reach = float(max_range) * float(np.max(dxy_len))  # horizontal reach [m]
        # floor and ceiling planes
        with np.errstate(divide="ignore", invalid="ignore"):
            t_floor = np.where(d[:, 2] < 0, -o[2] / d[:, 2], BIG).astype(np.float32)
            owner[t_floor < BIG] = -2
            best = t_floor
            if self.ceiling > o[2]:
                t_ceil = np.where(d[:, 2] > 0, (self.ceiling - o[2]) / d[:, 2], BIG).astype(np.float32)
                owner[t_ceil < best] = -3
                best = np.minimum(best, t_ceil)

        faces = self._faces_near(o[:2], -np.inf, np.inf, reach)
        if len(faces):
            a, b = self.face_a[faces], self.face_b[faces]
            # back faces (seen from inside their box) cannot be the first hit
            e = b - a
            faces = faces[(o[0] - a[:, 0]) * e[:, 1] - (o[1] - a[:, 1]) * e[:, 0] > 0]
        boxes = self._boxes_near(o[:2], reach)
        if len(boxes):
            zr = self.box_z[boxes]
            boxes = boxes[((o[2] > zr[:, 1]) & (zr[:, 1] > 0)) | ((o[2] < zr[:, 0]) & (zr[:, 0] > 0))]
        cyls = self._cylinders_near(o[:2], -np.inf, np.inf, reach)

        if groups is None:
            groups = [slice(0, n)]
        # horizontal angle intervals relative to the mean viewing direction
        if heading is None or ray_angles is None:
            mean = d[:, :2].mean(axis=0)
            heading = np.arctan2(mean[1], mean[0])
            ray_ang = wrap(np.arctan2(d[:, 1], d[:, 0]) - heading)
            bounds = [(ray_ang[idx].min(), ray_ang[idx].max()) for idx in groups]
        else:
            bounds = ray_angles if len(ray_angles) == len(groups) else [
                (ray_angles[idx].min(), ray_angles[idx].max()) for idx in groups]
        face_lo, face_hi = _interval(wrap(np.arctan2(self.face_a[faces, 1] - o[1], self.face_a[faces, 0] - o[0])
                                           - heading),
                                     wrap(np.arctan2(self.face_b[faces, 1] - o[1], self.face_b[faces, 0] - o[0])
                                           - heading))
        box_lo, box_hi = _disc_interval(o, self.box_center[boxes], np.hypot(*self.box_half[boxes].T), heading)
        cyl_lo, cyl_hi = _disc_interval(o, self.cyl_center[cyls], self.cyl_radius[cyls], heading)
        for idx, (lo, hi) in zip(groups, bounds, strict=True):
            t, who = self._cast_3d_group(
                o, d[idx], best[idx], owner[idx],
                faces[(face_hi >= lo) & (face_lo <= hi)],
                boxes[(box_hi >= lo) & (box_lo <= hi)],
                cyls[(cyl_hi >= lo) & (cyl_lo <= hi)])
            best[idx] = t
            owner[idx] = who
        far = best > max_range
        best[far] = np.inf
        owner[far] = -1
        return best, owner

    def _cast_3d_group(self, o, d, best, owner, faces, boxes, cyls):
        """The first hit of each ray ``o + t * d`` among the faces, box caps and cylinders given
        (index arrays), where it is nearer than ``best``: ``best`` and ``owner`` updated (and returned).
        Faces are tested before boxes, boxes before cylinders; within each, the first of equal hits."""
        o64 = np.asarray(o, dtype=np.float64)
        zb = self.box_z[boxes]
        box_cap = np.where(o64[2] > zb[:, 1], zb[:, 1], zb[:, 0])  # the top seen from above, else the bottom
        zc = self.cyl_z[cyls]
        cyl_cap = np.where(o64[2] > zc[:, 1], zc[:, 1], np.where(o64[2] < zc[:, 0], zc[:, 0], np.nan))
        _FIRST_HITS(
            o64, np.asarray(d, dtype=np.float64), best, owner,
            self.face_a[faces], self.face_b[faces], self.face_z[faces], self.face_owner[faces].astype(np.int32),
            self.box_center[boxes], np.cos(self.box_yaw[boxes]), np.sin(self.box_yaw[boxes]), self.box_half[boxes],
            box_cap, boxes.astype(np.int32),
            self.cyl_center[cyls], self.cyl_radius[cyls], zc, cyl_cap, self.cyl_owner[cyls].astype(np.int32))
        return best, owner

    # ------------------------------------------------------------------ culling
    def _faces_near(self, origin, z_lo, z_hi, reach):
        if not len(self.face_a):
            return np.zeros(0, dtype=int)
        zr = self.face_z
        near = _segment_distance(origin, self.face_a, self.face_b) <= reach
        return np.nonzero(near & (zr[:, 0] <= z_hi) & (zr[:, 1] >= z_lo))[0]

    def _boxes_near(self, origin, reach):
        if not len(self.box_center):
            return np.zeros(0, dtype=int)
        radius = np.hypot(self.box_half[:, 0], self.box_half[:, 1])
        return np.nonzero(np.linalg.norm(self.box_center - origin, axis=1) - radius <= reach)[0]

    def _cylinders_near(self, origin, z_lo, z_hi, reach):
        if not len(self.cyl_center):
            return np.zeros(0, dtype=int)
        near = np.linalg.norm(self.cyl_center - origin, axis=1) - self.cyl_radius <= reach
        return np.nonzero(near & (self.cyl_z[:, 0] <= z_hi) & (self.cyl_z[:, 1] >= z_lo))[0]


def _first_hits(o, d, best, owner, fa, fb, fz, fown, bc, bcos, bsin, bhalf, bcap, bidx, cc, cr, cz, ccap, cown):
    """Per ray (a numba kernel, :data:`_FIRST_HITS`; float64 arithmetic, ``best`` float32): the nearest hit
    ``t`` among vertical faces ``fa[j] -> fb[j]`` between heights ``fz[j]`` (owner ``fown[j]``), horizontal box caps
    at height ``bcap[j]`` (centre ``bc``, yaw cosine and sine, half sizes; owner ``bidx[j]``) and
    cylinders (centre ``cc``, radius ``cr``, heights ``cz``: their sides from outside and their cap at
    ``ccap[j]``, NaN for none; owner ``cown[j]``), each taken only when nearer than ``best[i]``, which
    is then replaced with ``owner[i]``."""
    for i in range(d.shape[0]):
        dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
        top = best[i]
        who = owner[i]
        for j in range(fa.shape[0]):
            ex, ey = fb[j, 0] - fa[j, 0], fb[j, 1] - fa[j, 1]
            den = dx * ey - dy * ex
            if den == 0.0:
                continue
            ax, ay = fa[j, 0] - o[0], fa[j, 1] - o[1]
            t = (ax * ey - ay * ex) / den
            u = (ax * dy - ay * dx) / den
            if t > 1e-9 and 0.0 <= u <= 1.0 and t < top:
                z = o[2] + t * dz
                if fz[j, 0] <= z <= fz[j, 1]:
                    top, who = t, fown[j]
        if dz != 0.0:
            for j in range(bc.shape[0]):
                t = (bcap[j] - o[2]) / dz
                if t > 0.0 and t < top:
                    px, py = o[0] + t * dx - bc[j, 0], o[1] + t * dy - bc[j, 1]
                    if (abs(px * bcos[j] + py * bsin[j]) <= bhalf[j, 0]
                            and abs(py * bcos[j] - px * bsin[j]) <= bhalf[j, 1]):
                        top, who = t, bidx[j]
        a = dx * dx + dy * dy
        for j in range(cc.shape[0]):
            t = np.inf
            if a > 0.0:
                ox, oy = o[0] - cc[j, 0], o[1] - cc[j, 1]
                bh = dx * ox + dy * oy
                disc = bh * bh - a * (ox * ox + oy * oy - cr[j] * cr[j])
                if disc >= 0.0:
                    ts = (-bh - np.sqrt(disc)) / a
                    if ts > 1e-9 and cz[j, 0] <= o[2] + ts * dz <= cz[j, 1]:
                        t = ts
            cap = ccap[j]
            if cap > 0.0 and dz != 0.0:  # (NaN: no cap seen)
                tc = (cap - o[2]) / dz
                if tc > 0.0 and tc < t:
                    px, py = o[0] + tc * dx - cc[j, 0], o[1] + tc * dy - cc[j, 1]
                    if px * px + py * py <= cr[j] * cr[j]:
                        t = tc
            if t < top:
                top, who = t, cown[j]
        best[i] = top
        owner[i] = who


_FIRST_HITS = lazy_njit(_first_hits, nogil=True)


def _segment_distance(p, a, b):
    """Distance from point ``p`` to each segment ``a[i] -> b[i]``."""
    e = b - a
    L2 = np.maximum(np.einsum("ij,ij->i", e, e), 1e-12)
    u = np.clip(np.einsum("ij,ij->i", p - a, e) / L2, 0.0, 1.0)
    return np.linalg.norm(a + u[:, None] * e - p, axis=1)


def _ray_segments(origin, dirs, a, b):
    """Ray parameters (N, M) where rays ``origin + t * dirs[n]`` cross segments ``a[m] -> b[m]``,
    and whether they do (t > 0, within the segment)."""
    dt = np.float32 if dirs.dtype == np.float32 else float
    ea = (a - origin).astype(dt)  # (M, 2)
    e = (b - a).astype(dt)
    dx, dy = dirs[:, 0:1], dirs[:, 1:2]
    den = dx * e[:, 1] - dy * e[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / den
        t = (ea[:, 0] * e[:, 1] - ea[:, 1] * e[:, 0]) * inv
        u = (ea[:, 0] * dy - ea[:, 1] * dx) * inv
    ok = (t > 1e-9) & (u >= 0) & (u <= 1)
    return t, ok


def _ray_circles(origin, dirs, centers, radii):
    """Ray parameter (N, M) of the first crossing of circles from outside; inf when missed."""
    oc = (origin - centers).astype(dirs.dtype)  # (M, 2)
    a = (dirs[:, 0:1] ** 2 + dirs[:, 1:2] ** 2)
    bh = dirs[:, 0:1] * oc[:, 0] + dirs[:, 1:2] * oc[:, 1]
    c = (oc[:, 0] ** 2 + oc[:, 1] ** 2 - radii.astype(dirs.dtype) ** 2)
    disc = bh * bh - a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (-bh - np.sqrt(disc)) / a
    return np.where((disc >= 0) & (t > 1e-9), t, np.inf)


def _interval(a, b):
    """Angle interval spanned by two relative angles; a pair straddling +-pi spans everything."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    wide = hi - lo > np.pi
    return np.where(wide, -np.pi, lo), np.where(wide, np.pi, hi)


def _disc_interval(o, centers, radii, heading):
    """Relative angle interval under which discs are seen from ``o`` (everything if ``o`` is inside)."""
    rel = centers - o[:2]
    dist = np.linalg.norm(rel, axis=1)
    mid = wrap(np.arctan2(rel[:, 1], rel[:, 0]) - heading)
    half = np.arcsin(np.clip(radii / np.maximum(dist, 1e-9), 0.0, 1.0))
    inside = (dist <= radii) | (np.abs(mid) + half > np.pi)
    return np.where(inside, -np.pi, mid - half), np.where(inside, np.pi, mid + half)
