"""Legs in a laser scan, paired into people (no ROS; vectorised over beams).

The Hokuyo sits 0.15 m above the floor: it cuts people at the ankles and shins. A scan is
split into clusters of consecutive returns closer than ``cluster_distance`` to each other (a
beam or two without a return inside a leg do not split it); a leg is a cluster of at least
``min_points`` returns, ``min_width``..``max_width`` wide (shins are 6 cm or more; chair and
table legs and lamp poles are thinner), standing out from what is behind it on both sides (a
bump on a wall is not a leg), or on one side and going on behind a leg that does on the other (the
far leg of a person seen at a slant, partly hidden by the near one). Its centre is the mean of its
returns moved back along the ray by 3/8 of its width: the returns lie on the near side of the leg.
Legs closer than ``max_pair_distance`` pair into a person at their midpoint; a leg with no partner
(the other one hidden behind it) is a person by itself, ``lone_shift`` beyond it unless a wall
close behind may hide the partner too (:func:`place_lone`). Such a lone leg with something nearer
than it by ``hidden_margin`` within ``max_pair_distance`` of it across the line of sight may have
its partner hidden behind that (another person crossing in front): :func:`partner_hidden` says so,
and the tracker trusts its side less (its centre is off the person's, up to a stride); so does a
lone leg at either end of the scan's bearings (:func:`partner_beyond_edge`), whose partner may be
out of view. :func:`in_view` tells what lies within those bearings at all.

Points are placed through the laser's 4x4 pose in the output frame, so the upside-down
mounting (rolled by pi: the scan runs clockwise) needs no special case.
"""

from dataclasses import dataclass

import numpy as np

from user_tracker_ni.association import distance_matrix

CENTRE_SHIFT = 0.375  # leg centre beyond the mean of its returns, in leg widths (3/4 radius)


@dataclass(frozen=True)
class LegParams:
    cluster_distance: float = 0.10  # [m] largest gap between neighbouring returns of one cluster
    min_points: int = 3  # returns in a leg
    max_gap_beams: int = 2  # beams in a row without a return that do not split a cluster
    min_width: float = 0.06  # [m] narrowest leg (end to end of its returns): shins are wider, chair legs not
    max_width: float = 0.25  # [m] widest leg (two legs seen as one included)
    edge_jump: float = 0.10  # [m] a leg stands this much in front of its neighbours on both sides
    max_pair_distance: float = 0.50  # [m] two legs of one person are at most this far apart
    max_range: float = 5.0  # [m] returns beyond are not used (sparse, noisy)
    hidden_margin: float = 0.3  # [m] a lone leg's partner may be hidden by what is this much nearer beside it
    lone_shift: float = 0.08  # [m] a lone leg nothing else hides the partner of stands in front of it: the
    # person's centre is this much farther along the line of sight (half a stance; 0: at the leg)
    lone_width: float = 0.16  # [m] ... if the leg is no wider than this (wider: both legs seen as one)

    def validate(self):
        for name in ("cluster_distance", "min_width", "max_width", "edge_jump", "max_pair_distance", "max_range",
                     "hidden_margin", "lone_width"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0 <= self.lone_shift < self.max_pair_distance:
            raise ValueError(f"lone_shift must be in [0, max_pair_distance), got {self.lone_shift}")
        if self.min_points < 2 or self.min_width >= self.max_width or self.max_gap_beams < 0:
            raise ValueError("need min_points >= 2, min_width < max_width and max_gap_beams >= 0")
        return self


def scan_points(ranges, angle_min, angle_increment, range_min, range_max, laser_pose):
    """(xy [N, 2] in the output frame, valid [N] bool) of a scan; ``laser_pose`` is the 4x4 pose
    of the laser frame in the output frame. Invalid returns (NaN, inf, out of limits) get NaN."""
    r = np.asarray(ranges, dtype=float)
    a = angle_min + angle_increment * np.arange(len(r))
    valid = np.isfinite(r) & (r > range_min) & (r < range_max)
    r = np.where(valid, r, np.nan)
    local = np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r)], axis=1)
    xy = local @ np.asarray(laser_pose)[:2, :3].T + np.asarray(laser_pose)[:2, 3]
    return xy, valid


def beam_ends(ranges, angle_min, angle_increment, range_min, range_max, laser_pose, no_return_range):
    """(ends [N, 2], hit [N]) of a scan's beams in the output frame, for a free-space memory: a
    return ends its beam (hit); no return (+inf, REP 117) lets it run ``no_return_range`` [m]
    through free space; an error (NaN, too near, negative) gives a NaN end (skipped)."""
    r = np.asarray(ranges, dtype=float)
    a = angle_min + angle_increment * np.arange(len(r))
    hit = np.isfinite(r) & (r > range_min) & (r < range_max)
    length = np.where(hit, r, np.where(np.isposinf(r), no_return_range, np.nan))
    local = np.stack([length * np.cos(a), length * np.sin(a), np.zeros_like(length)], axis=1)
    return local @ np.asarray(laser_pose)[:2, :3].T + np.asarray(laser_pose)[:2, 3], hit


def find_legs(xy, valid, sensor_xy, params, widths=False):
    """Leg centres [L, 2] among the scan points (in scan order); ``sensor_xy`` is the laser's
    position in the same frame (ranges are measured from it). A beam with no valid return inside
    a leg (a dropout) does not split it: clusters are made of the valid returns, broken where
    more than ``max_gap_beams`` beams in a row have none. With ``widths``, also each leg's width
    [L] (end to end of its returns)."""
    p = params
    xy = np.asarray(xy, dtype=float)
    rng = np.hypot(xy[:, 0] - sensor_xy[0], xy[:, 1] - sensor_xy[1])
    valid = valid & (rng <= p.max_range)
    idx = np.flatnonzero(valid)  # beams with a return, in scan order
    n = len(idx)
    if n == 0:
        return (np.zeros((0, 2)), np.zeros(0)) if widths else np.zeros((0, 2))
    pts, r = xy[idx], rng[idx]
    step = np.full(n, np.inf)
    step[1:] = np.hypot(pts[1:, 0] - pts[:-1, 0], pts[1:, 1] - pts[:-1, 1])
    gap = np.full(n, np.iinfo(np.int64).max)
    gap[1:] = np.diff(idx) - 1
    new_cluster = (step > p.cluster_distance) | (gap > p.max_gap_beams)
    new_cluster[0] = True
    label = np.cumsum(new_cluster) - 1
    starts = np.flatnonzero(new_cluster)
    ends = np.append(starts[1:], n) - 1
    counts = ends - starts + 1
    ok = counts >= p.min_points
    width = np.hypot(pts[ends, 0] - pts[starts, 0], pts[ends, 1] - pts[starts, 1])
    ok &= (width >= p.min_width) & (width <= p.max_width)
    # both neighbouring beams of the scan beyond the cluster (by range) or without a return:
    # it stands out (a bump on a wall does not)
    near = np.minimum(r[starts], r[ends])
    first, last = idx[starts], idx[ends]
    full = np.where(valid, rng, np.inf)
    before = np.where(first > 0, full[np.maximum(first - 1, 0)], np.inf)
    after = np.where(last < len(xy) - 1, full[np.minimum(last + 1, len(xy) - 1)], np.inf)
    out_before, out_after = before - near >= p.edge_jump, after - near >= p.edge_jump
    strict = ok & out_before & out_after
    # ... or, on one side, it goes on behind a leg that stands out: the far leg of a person seen at a
    # slant, partly hidden by the near one (dropped, the person was the near leg alone, up to half
    # their stance short of their centre)
    k = np.arange(len(starts))
    prev_leg = (k > 0) & (idx[np.maximum(starts - 1, 0)] == first - 1) & strict[np.maximum(k - 1, 0)]
    next_leg = (k < len(starts) - 1) & (idx[np.minimum(ends + 1, n - 1)] == last + 1) & \
        strict[np.minimum(k + 1, len(starts) - 1)]
    behind_prev = prev_leg & (r[starts] - before >= p.edge_jump)
    behind_next = next_leg & (r[ends] - after >= p.edge_jump)
    ok = strict | (ok & ((out_before & behind_next) | (behind_prev & out_after)))
    if not ok.any():
        return (np.zeros((0, 2)), np.zeros(0)) if widths else np.zeros((0, 2))
    sums = np.zeros((len(starts), 2))
    np.add.at(sums, label, pts)
    centroid = sums[ok] / counts[ok, None]
    # the returns lie on the leg's near side: their mean is about 3/4 of a radius short of the
    # centre (a circle sampled at even beam angles), so move it back along the ray
    ray = centroid - np.asarray(sensor_xy, dtype=float)
    ray /= np.maximum(np.hypot(ray[:, 0], ray[:, 1]), 1e-9)[:, None]
    centres = centroid + ray * (CENTRE_SHIFT * width[ok])[:, None]
    return (centres, width[ok]) if widths else centres


def place_lone(people, members, widths, hidden, sensor_xy, params):
    """People [P, 2] of :func:`pair_legs` (with its ``members``) with each lone leg's person moved
    ``lone_shift`` farther along the line of sight from ``sensor_xy``: a leg no wider than
    ``lone_width`` (``widths`` [L] of the legs) whose partner nothing nearer hides, the view's end
    does not cut off and no wall close behind may hide either (``hidden`` {leg index: bool}:
    :func:`lone_partners`) has it in its own shadow, behind it (a person standing side-on, or in
    mid-stride across the line of sight), and their centre lies between the two. Left at the leg, a
    person standing side-on 1 m from the laser was placed 0.105 m short of their centre (florence_sim's
    legs 0.2 m apart)."""
    people = np.array(people, dtype=float).reshape(-1, 2)
    if params.lone_shift <= 0:
        return people
    sensor = np.asarray(sensor_xy, dtype=float)
    for k, m in enumerate(members):
        if len(m) == 1 and not hidden.get(m[0], False) and widths[m[0]] <= params.lone_width:
            ray = people[k] - sensor
            people[k] += ray / max(float(np.hypot(*ray)), 1e-9) * params.lone_shift
    return people


def pair_legs(legs, params, members=False, groups=None):
    """People [P, 2] from leg centres: pairs closer than max_pair_distance meet at their midpoint
    (the closest pairs first), lone legs stand for a person each. ``groups`` [L]: only legs of the
    same group pair. With ``members``, also the leg indices of each person ([(i, j) or (i,)])."""
    legs = np.asarray(legs, dtype=float).reshape(-1, 2)
    n = len(legs)
    d = distance_matrix(legs, legs)
    i, j = np.triu_indices(n, k=1)
    close = d[i, j] < params.max_pair_distance
    if groups is not None:
        groups = np.asarray(groups)
        close &= groups[i] == groups[j]
    used = np.zeros(n, bool)
    people, who = [], []
    for k in np.argsort(d[i, j][close], kind="stable"):  # a handful of legs: greedy matching
        a, b = i[close][k], j[close][k]
        if not used[a] and not used[b]:
            used[a] = used[b] = True
            people.append((legs[a] + legs[b]) / 2)
            who.append((int(a), int(b)))
    people += list(legs[~used])
    who += [(int(a),) for a in np.flatnonzero(~used)]
    people = np.array(people).reshape(-1, 2)
    return (people, who) if members else people


def _beside(xy, valid, sensor_xy, legs, params):
    """[L, N] whether each valid scan point [N, 2] lies within ``max_pair_distance`` of each leg across
    the line of sight (the bearings that far to either side at its range), the points' ranges [N], the
    legs' [L] and the points (None, None, None, None without legs or points)."""
    legs = np.asarray(legs, dtype=float).reshape(-1, 2)
    pts = np.asarray(xy, dtype=float)[np.asarray(valid, bool)]
    if not len(legs) or not len(pts):
        return None, None, None, None
    sensor = np.asarray(sensor_xy, dtype=float)
    rel, leg_rel = pts - sensor, legs - sensor
    rng, leg_rng = np.hypot(rel[:, 0], rel[:, 1]), np.hypot(leg_rel[:, 0], leg_rel[:, 1])
    bearing, leg_bearing = np.arctan2(rel[:, 1], rel[:, 0]), np.arctan2(leg_rel[:, 1], leg_rel[:, 0])
    off = np.abs((bearing[None, :] - leg_bearing[:, None] + np.pi) % (2 * np.pi) - np.pi)  # [L, N]
    window = np.arctan2(params.max_pair_distance, np.maximum(leg_rng, 1e-6))[:, None]
    return off <= window, rng, leg_rng, pts


def partner_hidden(xy, valid, sensor_xy, legs, params):
    """For each leg [L, 2] (lone legs: their partner unseen): whether a scan point (``xy``, ``valid``
    in scan order, as for :func:`find_legs`) lies within ``max_pair_distance`` of it across the
    line of sight (the bearings that far to either side at its range) and ``hidden_margin`` or
    more nearer the laser: what may hide its partner."""
    beside, rng, leg_rng, _ = _beside(xy, valid, sensor_xy, legs, params)
    if beside is None:
        return np.zeros(len(np.asarray(legs).reshape(-1, 2)), bool)
    return np.any(beside & (rng[None, :] <= leg_rng[:, None] - params.hidden_margin), axis=1)


def partner_unseen_against(xy, valid, sensor_xy, legs, params):
    """For each leg [L, 2] (lone legs): whether a scan point beside it (as for :func:`partner_hidden`),
    not its own (farther than ``lone_width`` from its centre), lies less than ``max_pair_distance``
    beyond it or about as far (less than ``hidden_margin`` nearer): its partner may be there, seen but
    not taken for a leg (against a wall or a piece of furniture, or beside something it did not stand
    out from), rather than in its shadow."""
    beside, rng, leg_rng, pts = _beside(xy, valid, sensor_xy, legs, params)
    if beside is None:
        return np.zeros(len(np.asarray(legs).reshape(-1, 2)), bool)
    legs = np.asarray(legs, dtype=float).reshape(-1, 2)
    own = np.hypot(pts[None, :, 0] - legs[:, None, 0], pts[None, :, 1] - legs[:, None, 1]) <= params.lone_width
    near = (rng[None, :] > leg_rng[:, None] - params.hidden_margin) & \
        (rng[None, :] < leg_rng[:, None] + params.max_pair_distance)
    return np.any(beside & near & ~own, axis=1)


def lone_partners(xy, valid, lone_legs, angle_min, angle_max, laser_pose, params):
    """For each lone leg [L, 2] of a scan (``xy``, ``valid`` as for :func:`find_legs`, its bearings
    ``angle_min``..``angle_max`` [rad] from ``laser_pose`` 4x4): (whether its partner may be hidden by
    something nearer or beyond the view's end: :func:`partner_hidden`, :func:`partner_beyond_edge`;
    whether it may be seen but not taken for a leg: :func:`partner_unseen_against`), [L] each."""
    sensor = np.asarray(laser_pose)[:2, 3]
    hidden = partner_hidden(xy, valid, sensor, lone_legs, params) | \
        partner_beyond_edge(lone_legs, angle_min, angle_max, laser_pose, params)
    return hidden, partner_unseen_against(xy, valid, sensor, lone_legs, params)


def in_view(points, angle_min, angle_max, laser_pose, margin=0.1):
    """Boolean [N]: whether the points [N, 2] (output frame) lie within the scan's bearings,
    ``angle_min``..``angle_max`` [rad] in the laser frame, ``margin`` [rad] (or [N] of them)
    inside either end: the laser cannot see a person outside them (behind the robot) at all.
    Bearings are taken in the laser's plane, so the upside-down mounting (its scan runs
    clockwise) needs no special case."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pose = np.asarray(laser_pose, dtype=float)
    lo, hi = min(angle_min, angle_max), max(angle_min, angle_max)
    if hi - lo >= 2 * np.pi:
        return np.ones(len(pts), bool)  # all round
    world = np.column_stack([pts, np.full(len(pts), pose[2, 3])])
    local = (world - pose[:3, 3]) @ pose[:3, :3]  # output -> laser frame (R^T (p - t))
    bearing = np.arctan2(local[:, 1], local[:, 0])
    # the bearing measured from the middle of the scan, within -pi..pi
    off = (bearing - (lo + hi) / 2 + np.pi) % (2 * np.pi) - np.pi
    return np.abs(off) <= (hi - lo) / 2 - margin


def partner_beyond_edge(legs, angle_min, angle_max, laser_pose, params):
    """For each leg [L, 2] (lone legs): whether it lies within ``max_pair_distance`` (across the
    line of sight, at its range) of either end of the scan's bearings, where its partner may be
    out of the laser's view: at the edge of the view a person is one leg, up to a stride off
    their centre, and it would drag their track sideways as they go out of view."""
    legs = np.asarray(legs, dtype=float).reshape(-1, 2)
    if not len(legs):
        return np.zeros(0, bool)
    rng = np.hypot(*(legs - np.asarray(laser_pose, dtype=float)[:2, 3]).T)
    window = np.arctan2(params.max_pair_distance, np.maximum(rng, 1e-6))
    return ~in_view(legs, angle_min, angle_max, laser_pose, margin=window)


def detect(ranges, angle_min, angle_increment, range_min, range_max, laser_pose, params):
    """(legs [L, 2], people [P, 2]) of one scan in the frame of ``laser_pose`` (4x4): the legs
    paired, a lone leg's person placed behind it where nothing else may hide its partner
    (:func:`place_lone`)."""
    xy, valid = scan_points(ranges, angle_min, angle_increment, range_min, range_max, laser_pose)
    sensor = np.asarray(laser_pose)[:2, 3]
    legs, widths = find_legs(xy, valid, sensor, params, widths=True)
    people, members = pair_legs(legs, params, members=True)
    lone = [m[0] for m in members if len(m) == 1]
    hidden, unseen = lone_partners(xy, valid, legs[lone], angle_min, angle_min + angle_increment * (len(ranges) - 1),
                                   laser_pose, params)
    return legs, place_lone(people, members, widths, dict(zip(lone, (hidden | unseen).tolist(), strict=True)), sensor,
                            params)
