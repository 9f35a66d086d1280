"""Legs in a laser scan, paired into people (no ROS; vectorised over beams).

The Hokuyo sits 0.15 m above the floor: it cuts people at the ankles and shins. A scan is
split into clusters of consecutive returns closer than ``cluster_distance`` to each other;
a leg is a cluster of at least ``min_points`` returns, ``min_width``..``max_width`` wide,
standing out from what is behind it on both sides (a bump on a wall is not a leg). Its centre
is the mean of its returns moved back along the ray by 3/8 of its width: the returns lie on the
near side of the leg. Legs
closer than ``max_pair_distance`` pair into a person at their midpoint; a leg with no
partner (the other one hidden behind it) is a person by itself.

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
    min_width: float = 0.03  # [m] narrowest leg (end to end of its returns)
    max_width: float = 0.25  # [m] widest leg (two legs seen as one included)
    edge_jump: float = 0.10  # [m] a leg stands this much in front of its neighbours on both sides
    max_pair_distance: float = 0.50  # [m] two legs of one person are at most this far apart
    max_range: float = 5.0  # [m] returns beyond are not used (sparse, noisy)

    def validate(self):
        for name in ("cluster_distance", "min_width", "max_width", "edge_jump", "max_pair_distance", "max_range"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.min_points < 2 or self.min_width >= self.max_width:
            raise ValueError("need min_points >= 2 and min_width < max_width")
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


def find_legs(xy, valid, sensor_xy, params):
    """Leg centres [L, 2] among the scan points (in scan order); ``sensor_xy`` is the laser's
    position in the same frame (ranges are measured from it)."""
    p = params
    rng = np.hypot(xy[:, 0] - sensor_xy[0], xy[:, 1] - sensor_xy[1])
    valid = valid & (rng <= p.max_range)
    n = len(xy)
    if n == 0 or not valid.any():
        return np.zeros((0, 2))
    step = np.full(n, np.inf)
    step[1:] = np.hypot(xy[1:, 0] - xy[:-1, 0], xy[1:, 1] - xy[:-1, 1])
    new_cluster = ~valid | ~np.roll(valid, 1) | (step > p.cluster_distance)
    new_cluster[0] = True
    label = np.cumsum(new_cluster) - 1
    starts = np.flatnonzero(new_cluster)
    ends = np.append(starts[1:], n) - 1
    counts = ends - starts + 1
    ok = valid[starts] & (counts >= p.min_points)
    width = np.hypot(xy[ends, 0] - xy[starts, 0], xy[ends, 1] - xy[starts, 1])
    ok &= (width >= p.min_width) & (width <= p.max_width)
    # both neighbours beyond the cluster (by range) or no return there: it stands out
    near = np.minimum(rng[starts], rng[ends])
    before = np.where(starts > 0, rng[np.maximum(starts - 1, 0)], np.inf)
    after = np.where(ends < n - 1, rng[np.minimum(ends + 1, n - 1)], np.inf)
    before = np.where(np.isfinite(before), before, np.inf)
    after = np.where(np.isfinite(after), after, np.inf)
    ok &= (before - near >= p.edge_jump) & (after - near >= p.edge_jump)
    if not ok.any():
        return np.zeros((0, 2))
    keep = ok[label] & valid
    sums = np.zeros((len(starts), 2))
    np.add.at(sums, label[keep], xy[keep])
    centroid = sums[ok] / counts[ok, None]
    # the returns lie on the leg's near side: their mean is about 3/4 of a radius short of the
    # centre (a circle sampled at even beam angles), so move it back along the ray
    ray = centroid - np.asarray(sensor_xy, dtype=float)
    ray /= np.maximum(np.hypot(ray[:, 0], ray[:, 1]), 1e-9)[:, None]
    return centroid + ray * (CENTRE_SHIFT * width[ok])[:, None]


def pair_legs(legs, params):
    """People [P, 2] from leg centres: pairs closer than max_pair_distance meet at their midpoint
    (the closest pairs first), lone legs stand for a person each."""
    legs = np.asarray(legs, dtype=float).reshape(-1, 2)
    n = len(legs)
    d = distance_matrix(legs, legs)
    i, j = np.triu_indices(n, k=1)
    close = d[i, j] < params.max_pair_distance
    used = np.zeros(n, bool)
    people = []
    for k in np.argsort(d[i, j][close], kind="stable"):  # a handful of legs: greedy matching
        a, b = i[close][k], j[close][k]
        if not used[a] and not used[b]:
            used[a] = used[b] = True
            people.append((legs[a] + legs[b]) / 2)
    people += list(legs[~used])
    return np.array(people).reshape(-1, 2)


def detect(ranges, angle_min, angle_increment, range_min, range_max, laser_pose, params):
    """(legs [L, 2], people [P, 2]) of one scan in the frame of ``laser_pose`` (4x4)."""
    xy, valid = scan_points(ranges, angle_min, angle_increment, range_min, range_max, laser_pose)
    legs = find_legs(xy, valid, np.asarray(laser_pose)[:2, 3], params)
    return legs, pair_legs(legs, params)
