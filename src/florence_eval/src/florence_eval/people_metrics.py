"""Judging a people tracker against the simulator's ground truth (no ROS).

The tracker works in the robot's odometry frame, the ground truth is in the map frame: both are
compared where the robot perceives them, in its own base frame at each instant, the tracks
through the robot's odometry pose, the ground truth through its true pose. Nothing of the ground
truth reaches the tracker.

Who counts (the region of interest): a person whose centre is ``near``..``far`` from the Kinect,
inside its horizontal field of view, and (when a line-of-sight test is given) not hidden by walls
or furniture. Tracks of people outside it neither score nor count as false positives.
"""

import math
from dataclasses import dataclass

import numpy as np

from florence_common import angles, pose
from florence_eval.mot import MotAccumulator


@dataclass(frozen=True)
class KinectView:
    """Where the Kinect sees a person's centre: its optical axis's origin in the base frame."""

    x: float = 0.10  # [m] camera in the base frame
    y: float = -0.02
    near: float = 0.8  # [m]
    far: float = 4.0  # [m]
    hfov: float = math.radians(57.0)  # [rad]
    margin: float = math.radians(4.0)  # [rad] a person's centre this far inside the edge: in view

    def sees(self, xy_base):
        """Boolean [N]: the points (base frame) are within range and the field of view."""
        xy = np.asarray(xy_base, float).reshape(-1, 2)
        dx, dy = xy[:, 0] - self.x, xy[:, 1] - self.y
        d = np.hypot(dx, dy)
        bearing = np.abs(np.arctan2(dy, dx))
        return (d >= self.near) & (d <= self.far) & (bearing <= self.hfov / 2 - self.margin)


class LineOfSight:
    """visible(robot_pose_map, xy_map) for :func:`frames`: the Kinect would see the person's upper
    body past the world's walls and furniture (florence_sim's scene, without people): of three
    rays from the camera to the torso (its centre and ``spread`` [m] to either side, ``height``
    [m] above the floor), at least two reach it. ``camera``: the camera's (x, y, z) in the base
    frame [m]."""

    def __init__(self, scene, camera=(0.10, -0.02, 0.54), height=1.1, spread=0.15, body_radius=0.2):
        self.scene, self.camera = scene, np.asarray(camera, float)
        self.height, self.spread, self.radius = height, spread, body_radius

    def __call__(self, robot_pose, xy):
        origin = np.array([*pose.transform_points(robot_pose, [self.camera[:2]])[0], self.camera[2]])
        to = np.array([xy[0], xy[1], self.height]) - origin
        dist = float(np.hypot(to[0], to[1]))
        if dist < 1e-6:
            return True
        side = np.array([-to[1], to[0], 0.0]) / dist * self.spread
        targets = np.stack([to, to + side, to - side])
        lengths = np.linalg.norm(targets, axis=1)
        t, _ = self.scene.cast_3d(origin, targets / lengths[:, None], float(lengths.max()) + 1.0)
        clear = t >= lengths - self.radius
        return int(np.count_nonzero(clear)) >= 2


def interpolate_poses(times, poses, t):
    """(x, y, yaw) at time ``t`` from rows of a pose history (linear; yaw along the short way);
    None outside the history."""
    times = np.asarray(times, float)
    if len(times) == 0 or t < times[0] or t > times[-1]:
        return None
    k = int(np.searchsorted(times, t))
    if k == 0 or times[k] == t:
        return tuple(float(v) for v in poses[k])
    t0, t1 = times[k - 1], times[k]
    a = (t - t0) / (t1 - t0) if t1 > t0 else 0.0
    p0, p1 = poses[k - 1], poses[k]
    return (float(p0[0] + a * (p1[0] - p0[0])), float(p0[1] + a * (p1[1] - p0[1])),
            float(p0[2] + a * angles.diff(p1[2], p0[2])))


def to_base(robot_pose, xy):
    """Points [N, 2] of the robot's parent frame into its base frame."""
    xy = np.asarray(xy, float).reshape(-1, 2)
    return pose.transform_points(pose.inverse(robot_pose), xy) if len(xy) else xy


@dataclass
class Frame:
    """One tracker output with what the robot and the people truly did at its stamp."""

    t: float
    truth: dict  # person id -> (x, y) in the base frame
    tracks: dict  # persistent id -> (x, y) in the base frame
    ni: dict  # persistent id -> ni id
    care: dict  # person id -> counts (in view)
    hyp_care: dict = None  # persistent id -> in view (an unmatched one there is a false positive)


def frames(tracker_msgs, people_msgs, truth_poses, odom_poses, view, visible=None):
    """Frames of the tracker's messages.

    tracker_msgs: [(t, {pid: (x, y) in odom}, {pid: ni_id})]; people_msgs: [(t, {id: (x, y) in
    map})]; truth_poses / odom_poses: (times [N], poses [N, 3]); visible(robot_pose_map, xy_map) ->
    bool, a line-of-sight test (optional)."""
    out = []
    p_times = np.array([m[0] for m in people_msgs], float)
    for t, tracks, ni in tracker_msgs:
        truth_pose = interpolate_poses(*truth_poses, t)
        odom_pose = interpolate_poses(*odom_poses, t)
        k = int(np.searchsorted(p_times, t))
        if truth_pose is None or odom_pose is None or k == 0 or k >= len(people_msgs):
            continue
        (t0, before), (t1, after) = people_msgs[k - 1], people_msgs[k]
        a = (t - t0) / (t1 - t0) if t1 > t0 else 0.0
        gt_map = {pid: (before[pid][0] + a * (after[pid][0] - before[pid][0]),
                        before[pid][1] + a * (after[pid][1] - before[pid][1]))
                  for pid in before if pid in after}
        ids = list(gt_map)
        gt_base = to_base(truth_pose, [gt_map[i] for i in ids])
        in_view = view.sees(gt_base) if ids else np.zeros(0, bool)
        care = {}
        for i, pid in enumerate(ids):
            care[pid] = bool(in_view[i]) and (visible is None or visible(truth_pose, gt_map[pid]))
        hyp_ids = list(tracks)
        hyp_base = to_base(odom_pose, [tracks[h] for h in hyp_ids])
        hyp_in_view = view.sees(hyp_base) if hyp_ids else np.zeros(0, bool)
        out.append(Frame(t, {pid: tuple(gt_base[i]) for i, pid in enumerate(ids)},
                         {h: tuple(hyp_base[j]) for j, h in enumerate(hyp_ids)}, dict(ni), care,
                         {h: bool(hyp_in_view[j]) for j, h in enumerate(hyp_ids)}))
    return out


def evaluate(frame_list, gate=0.5, return_gap=1.5):
    """CLEAR MOT of the frames plus the re-identification of returns: a person matched in view,
    then not matched in view for at least ``return_gap`` [s], then matched in view again,
    returned; under their old persistent id or not. Also: the share of frames each person was
    matched in, whether in view or not (the laser's share beside the robot)."""
    acc = MotAccumulator(gate=gate)
    last_match = {}  # person -> (t, persistent id)
    returns, returns_same = 0, 0
    matched_frames, present_frames = {}, {}
    for f in frame_list:
        matches = acc.update(f.t, f.truth, f.tracks, f.care, f.hyp_care)
        for person in f.truth:
            present_frames[person] = present_frames.get(person, 0) + 1
        for person, h in matches.items():
            matched_frames[person] = matched_frames.get(person, 0) + 1
            if not f.care.get(person, True):
                continue
            prev = last_match.get(person)
            if prev is not None and f.t - prev[0] >= return_gap:
                returns += 1
                returns_same += int(prev[1] == h)
            last_match[person] = (f.t, h)
    summary = acc.summary()
    summary.update({
        "returns": returns, "returns_with_old_id": returns_same,
        "tracked_share": {p: matched_frames.get(p, 0) / n for p, n in present_frames.items()},
        "switches": [list(s) for s in acc.switch_log],
        "misses_at": [list(m) for m in acc.miss_log],
        "false_positives_at": [list(f) for f in acc.false_positive_log],
    })
    return summary
