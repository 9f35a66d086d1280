"""GMapping's scan matcher, per particle, against the particle's own hit map (numba, no ROS).

(openslam_gmapping ``scanmatcher.{h,cpp}``: ``score``, ``likelihoodAndScore``, ``optimize``.)

For a pose, each used beam (every (lskip + 1)-th, with a reading up to maxUrange) ends at a point. Among the
(2 kernelSize + 1)^2 cells around it, the candidates are the cells some beam ended in, whose beams came from
the same side as this one (their summed directions point the same way). The beam's mismatch d is measured
to the *surface* through the candidate whose mean hit point is nearest: the hits of the window's candidates
whose means lie within SURFACE_REACH cells of that one, fitted by their mean mu and covariance C (with a
floor of SURFACE_NOISE across): d^2 = lambda_min (p - mu)^T C^-1 (p - mu), the distance across a wall and
to the mean at a corner or a table leg. Where the hits form a line, the beam must also come from the side of
its normal that the hits came from. Then, as GMapping,

    score      = sum over matched beams of exp(-d^2 / sigma)
    likelihood = sum over matched beams of -d^2 / lsigma  +  (unmatched beams) x -0.5 / lsigma

``optimize`` is GMapping's hill climb: from the odometry pose try +-lstep along the map's x and y axes and
+-astep in yaw, move to the best of the six while the score improves; when none improves, halve both steps;
stop once nothing improves after ``iterations`` halvings.

Two differences from openslam_gmapping, on purpose (the README says why): GMapping's d is the distance to the
nearest candidate's mean hit point, which is not smallest at the true pose (an end point is as likely half a
cell along a wall from a mean as on it); and its "free cell in front" check adds the *absolute* map index of
the small vector (free point - end point) to each candidate (``world2map(pfree - phit)``), which lands far
outside the beam's neighbourhood, so it never does what it says. The side checks here do it.
"""

import math

import numba
import numpy as np

from gmapping.particle_maps import HITS, PATCH_BITS, PATCH_MASK, SUM_UX, SUM_UY, SUM_X, SUM_XX, SUM_XY, SUM_Y, SUM_YY

NULL_LIKELIHOOD = -0.5  # an unmatched beam's likelihood, times 1 / lsigma
SURFACE_NOISE = 0.01  # [m] least spread of a surface across itself (the fit's floor)
ELONGATED = 4.0  # a surface whose spread along is this many times its spread across is a line
SURFACE_REACH = 1.5  # [cells] the window's cells whose mean lies this near the nearest one's make its surface


@numba.njit(cache=True, nogil=True, inline="always")
def _patch(index, ox, oy, p, cx, cy):
    """Patch id holding cell (cx, cy) in particle p's map, -1 if none."""
    qx = (cx >> PATCH_BITS) - ox
    qy = (cy >> PATCH_BITS) - oy
    if qx < 0 or qy < 0 or qy >= index.shape[1] or qx >= index.shape[2]:
        return -1
    return index[p, qy, qx]


@numba.njit(cache=True, nogil=True)
def _match_beams(pool, index, ox, oy, p, x, y, th, lx, ly, bcos, bsin, ranges, usable, delta, sigma, kernel,
                 lskip, lsigma):
    """(score, likelihood, matched beams) of particle p's scan at pose (x, y, th)."""
    c, s = math.cos(th), math.sin(th)
    lox = x + c * lx - s * ly
    loy = y + s * lx + c * ly
    score = 0.0
    like = 0.0
    matched = 0
    nohit = NULL_LIKELIHOOD / lsigma
    floor = SURFACE_NOISE * SURFACE_NOISE
    window = np.empty(((2 * kernel + 1) ** 2, 8))  # a candidate's hits, sums, squares and directions
    for b in range(lskip, ranges.shape[0], lskip + 1):
        r = ranges[b]
        if not (r <= usable and r > 0.0):
            continue
        dc = c * bcos[b] - s * bsin[b]
        ds = s * bcos[b] + c * bsin[b]
        hx = lox + r * dc
        hy = loy + r * ds
        hcx = math.floor(hx / delta)
        hcy = math.floor(hy / delta)
        # the end point relative to its cell's centre
        px = hx - (hcx + 0.5) * delta
        py = hy - (hcy + 0.5) * delta
        # the window's candidates (hit, by beams from this side), kept for the second pass ...
        count = 0
        best = math.inf
        nearest = -1
        for kx in range(-kernel, kernel + 1):
            for ky in range(-kernel, kernel + 1):
                pid = _patch(index, ox, oy, p, hcx + kx, hcy + ky)
                if pid < 0:
                    continue
                i = (hcy + ky) & PATCH_MASK
                j = (hcx + kx) & PATCH_MASK
                m = pool[pid, HITS, i, j]
                if m <= 0.0 or pool[pid, SUM_UX, i, j] * dc + pool[pid, SUM_UY, i, j] * ds <= 0.0:
                    continue  # no hit, or a surface seen from the other side
                ax = kx * delta
                ay = ky * delta
                w = window[count]
                w[0] = m
                w[1] = pool[pid, SUM_X, i, j] + m * ax  # sums relative to the end point's cell centre
                w[2] = pool[pid, SUM_Y, i, j] + m * ay
                cx_ = pool[pid, SUM_X, i, j]
                cy_ = pool[pid, SUM_Y, i, j]
                w[3] = pool[pid, SUM_XX, i, j] + 2.0 * ax * cx_ + m * ax * ax
                w[4] = pool[pid, SUM_XY, i, j] + ax * cy_ + ay * cx_ + m * ax * ay
                w[5] = pool[pid, SUM_YY, i, j] + 2.0 * ay * cy_ + m * ay * ay
                w[6] = pool[pid, SUM_UX, i, j]
                w[7] = pool[pid, SUM_UY, i, j]
                ex = px - w[1] / m
                ey = py - w[2] / m
                d2 = ex * ex + ey * ey
                if d2 < best:
                    best, nearest = d2, count
                count += 1
        if nearest < 0:
            like += nohit
            continue
        # ... and the surface through the nearest: the candidates whose mean lies within SURFACE_REACH of its mean
        # (the same surface, not the far face of a thin wall)
        cmx = window[nearest, 1] / window[nearest, 0]
        cmy = window[nearest, 2] / window[nearest, 0]
        reach2 = (SURFACE_REACH * delta) ** 2
        n = 0.0
        sx = sy = sxx = sxy = syy = sux = suy = 0.0
        for k in range(count):
            w = window[k]
            dx = w[1] / w[0] - cmx
            dy = w[2] / w[0] - cmy
            if dx * dx + dy * dy > reach2:
                continue
            n += w[0]
            sx += w[1]
            sy += w[2]
            sxx += w[3]
            sxy += w[4]
            syy += w[5]
            sux += w[6]
            suy += w[7]
        if n <= 0.0:
            like += nohit
            continue
        mx = sx / n
        my = sy / n
        ex = px - mx
        ey = py - my
        if n < 3.0:
            d2 = ex * ex + ey * ey
        else:
            a = sxx / n - mx * mx + floor
            bb = sxy / n - mx * my
            cc = syy / n - my * my + floor
            det = a * cc - bb * bb
            root = math.sqrt(0.25 * (a - cc) * (a - cc) + bb * bb)
            lam = 0.5 * (a + cc) - root
            if 0.5 * (a + cc) + root > ELONGATED * lam:
                # a line: the beam must come from the side its hits came from (at a grazing angle the beams'
                # directions alone cannot tell the two faces of a thin wall apart, their normal parts can)
                nx, ny = (bb, lam - a) if abs(a - lam) > abs(cc - lam) else (lam - cc, bb)
                if (nx * sux + ny * suy) * (nx * dc + ny * ds) <= 0.0:
                    like += nohit
                    continue
            d2 = lam * (cc * ex * ex - 2.0 * bb * ex * ey + a * ey * ey) / det
        score += math.exp(-d2 / sigma)
        like -= d2 / lsigma
        matched += 1
    return score, like, matched


@numba.njit(cache=True, nogil=True)
def _optimize(pool, index, ox, oy, p, x, y, th, lx, ly, bcos, bsin, ranges, usable, delta, sigma, kernel, lskip,
              lsigma, lstep, astep, iterations):
    """GMapping's hill climb from (x, y, th): (x, y, th, best score)."""
    current = _match_beams(pool, index, ox, oy, p, x, y, th, lx, ly, bcos, bsin, ranges, usable, delta, sigma,
                           kernel, lskip, lsigma)[0]
    best = -1.0
    ld, ad = lstep, astep
    refinement = 0
    while True:
        if best >= current:
            refinement += 1
            ld *= 0.5
            ad *= 0.5
        best = current
        bx, by, bth = x, y, th
        for move in range(6):
            tx, ty, tth = x, y, th
            if move == 0:
                tx += ld
            elif move == 1:
                tx -= ld
            elif move == 2:
                ty -= ld
            elif move == 3:
                ty += ld
            elif move == 4:
                tth += ad
            else:
                tth -= ad
            local = _match_beams(pool, index, ox, oy, p, tx, ty, tth, lx, ly, bcos, bsin, ranges, usable, delta,
                                 sigma, kernel, lskip, lsigma)[0]
            if local > current:
                current = local
                bx, by, bth = tx, ty, tth
        x, y, th = bx, by, bth
        if not (current > best or refinement < iterations):
            break
    return x, y, th, best


@numba.njit(cache=True, nogil=True)
def _match_all(pool, index, ox, oy, poses, lx, ly, bcos, bsin, ranges, usable, delta, sigma, kernel, lskip, lsigma,
               lstep, astep, iterations, minimum_score, out_poses, out_score, out_like, out_matched):
    for p in range(poses.shape[0]):
        x, y, th = poses[p, 0], poses[p, 1], poses[p, 2]
        mx, my, mth, score = _optimize(pool, index, ox, oy, p, x, y, th, lx, ly, bcos, bsin, ranges, usable, delta,
                                       sigma, kernel, lskip, lsigma, lstep, astep, iterations)
        if score > minimum_score:
            x, y, th = mx, my, mth
        out_poses[p, 0], out_poses[p, 1], out_poses[p, 2] = x, y, th
        out_score[p] = score
        _, like, matched = _match_beams(pool, index, ox, oy, p, x, y, th, lx, ly, bcos, bsin, ranges, usable, delta,
                                        sigma, kernel, lskip, lsigma)
        out_like[p] = like
        out_matched[p] = matched


class MatchSettings:
    """The scan matcher's parameters (slam_gmapping's names)."""

    def __init__(self, sigma=0.05, kernelSize=1, lstep=0.05, astep=0.05, iterations=5, lsigma=0.075, lskip=0,
                 minimumScore=0.0):
        self.sigma, self.kernel, self.lstep, self.astep = float(sigma), int(kernelSize), float(lstep), float(astep)
        self.iterations, self.lsigma, self.lskip = int(iterations), float(lsigma), int(lskip)
        self.minimum_score = float(minimumScore)


def match(maps, poses, laser, ranges, usable, settings):
    """Scan-match every particle against its own map.

    maps: ParticleMaps; poses [N, 3] (base poses in the map); laser: LaserGeometry; ranges [B] [m] (inf: no
    reading); usable: maxUrange [m]. Returns (poses [N, 3]: the matched pose where the score beat
    minimumScore, else the given one; score [N]: the hill climb's best score; likelihood [N] at the returned
    pose; matched [N]: beams that found a surface there)."""
    poses = np.ascontiguousarray(poses, dtype=np.float64).reshape(-1, 3)
    n = len(poses)
    out = np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n, np.int64)
    st = settings
    _match_all(maps.pool, maps.index, maps.origin[0], maps.origin[1], poses, laser.x, laser.y, laser.cos, laser.sin,
               np.asarray(ranges, np.float64), float(usable), maps.delta, st.sigma, st.kernel, st.lskip, st.lsigma,
               st.lstep, st.astep, st.iterations, st.minimum_score, *out)
    return out


def score_pose(maps, particle, pose, laser, ranges, usable, settings):
    """(score, likelihood, matched beams) of one particle's scan at ``pose`` (x, y, yaw) (tests, diagnostics)."""
    st = settings
    return _match_beams(maps.pool, maps.index, maps.origin[0], maps.origin[1], int(particle), float(pose[0]),
                        float(pose[1]), float(pose[2]), laser.x, laser.y, laser.cos, laser.sin,
                        np.asarray(ranges, np.float64), float(usable), maps.delta, st.sigma, st.kernel, st.lskip,
                        st.lsigma)
