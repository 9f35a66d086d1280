"""From sensor readings to tracks (no ROS): the detectors, the free-space memory and the tracker
wired together once, for the node and for offline evaluations alike.

The caller gives each reading with its time and the poses it needs (4x4, from tf on the robot):

- a depth frame: the image [m], its :class:`florence_common.camera.Camera`, the optical frame's pose in the
  base frame, the base's pose in the fixed frame, and optionally the registered colour image;
- a scan: its ranges and geometry and the laser's pose in the fixed frame (the upside-down
  mounting is in that pose).

Laser detections carry whether they lie in free space (free_space.py, as it was before this scan),
which the tracker needs to confirm a track the laser alone started; each scan then updates that
memory. With the robot's map (:meth:`Pipeline.set_map`) and the fixed frame's pose in it at the
reading's time (``fixed_in_map``), detections on thin static structure are marked
(static_map.py); without either, nothing is.
"""

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from florence_common import angles
from user_tracker_ni import depth_people, free_space, laser_legs, reid
from user_tracker_ni.tracker import KINECT, LASER, Detection, Tracker

KINECT_STD, LASER_STD = 0.08, 0.05  # [m] position noise of a detection of each sensor
# [m] across the line of sight, that of a detection of a person partly hidden behind somebody or
# something nearer (depth_people's ``occluded``; a lone leg whose partner may be hidden,
# laser_legs.partner_hidden): its centre is that of the side in view, up to half a body or a
# stride off theirs, while its range is good; across it the filter's prediction leads, and it
# teaches the filter no velocity (two people crossing: the one behind had their track dragged to
# the side in view, and their velocity with it, then coasting 0.5 m off while the one in front
# hid them)
OCCLUDED_ACROSS_STD = 1.0


def _partly_hidden(hidden, x, y, sensor_xy):
    """Detection fields of a person seen at (x, y) [m] from ``sensor_xy``: across_std and the line of
    sight when ``hidden``, nothing otherwise."""
    if not hidden:
        return {}
    return {"across_std": OCCLUDED_ACROSS_STD, "sight": (float(x - sensor_xy[0]), float(y - sensor_xy[1]))}


@dataclass
class PipelineParams:
    depth: depth_people.DepthParams = field(default_factory=depth_people.DepthParams)
    legs: laser_legs.LegParams = field(default_factory=laser_legs.LegParams)
    free: free_space.FreeSpaceParams = field(default_factory=free_space.FreeSpaceParams)
    tracker: object = None  # tracker.TrackerParams (None: the defaults)


class Pipeline:
    def __init__(self, params=None):
        self.p = params or PipelineParams()
        self.tracker = Tracker(self.p.tracker)
        self.free = free_space.FreeSpace(self.p.free)
        self.rejected = Counter()  # depth clusters that were not people, by reason
        self.counts = Counter()  # detections by sensor (and "on the map's structure")
        self.map = None  # static_map.StaticMap

    def set_map(self, static_map):
        """The robot's map (a static_map.StaticMap), or None to judge without one."""
        self.map = static_map

    def _on_structure(self, xy_fixed, fixed_in_map):
        if self.map is None or fixed_in_map is None or len(xy_fixed) == 0:
            return np.zeros(len(xy_fixed), bool)
        m = np.asarray(fixed_in_map, float)
        xy = np.asarray(xy_fixed, float).reshape(-1, 2)
        on = self.map.on_structure(xy @ m[:2, :2].T + m[:2, 3])
        self.counts["on the map's structure"] += int(np.count_nonzero(on))
        return on

    def reset(self):
        """Forget every track (Stop); persistent ids are kept, and so is the free-space memory:
        it is what the laser saw of the floor, not a detection, and it stays valid in the fixed
        frame while the robot turns (detect_users stops the tracker for each 45 degree step)."""
        self.tracker.reset()

    def on_depth(self, t, depth, camera, camera_in_base, base_in_fixed, rgb=None, fixed_in_map=None):
        """Fuse one depth frame taken at ``t`` [s]; returns the detections (fixed frame).
        ValueError for an image that does not match its camera."""
        people, rejected = depth_people.detect(depth, camera, camera_in_base, self.p.depth, rgb)
        self.rejected.update(rejected)
        base = np.asarray(base_in_fixed, float)
        xy = np.array([base[:2, :2] @ (p.x, p.y) + base[:2, 3] for p in people]).reshape(-1, 2)
        on = self._on_structure(xy, fixed_in_map)
        yaw = math.atan2(base[1, 0], base[0, 0])
        camera_xy = (base @ np.asarray(camera_in_base, float)[:, 3])[:2]
        dets = [Detection(float(x), float(y), KINECT, KINECT_STD, p.signature, on_structure=bool(o),
                          facing=None if p.facing is None else angles.wrap(p.facing + yaw), posture=p.posture,
                          **_partly_hidden(p.occluded, x, y, camera_xy))
                for (x, y), p, o in zip(xy, people, on, strict=True)]
        self.tracker.update(t, dets, KINECT)
        self.counts[KINECT] += len(dets)
        self._look_close(t, depth, camera, camera_in_base, base, rgb)
        self._note_clear_view(t, depth, camera, camera_in_base, base)
        return dets

    def _look_close(self, t, depth, camera, camera_in_base, base_in_fixed, rgb):
        """Keep the confirmed people this frame did not detect and who stand within ``close_range``
        of the camera, where the image cuts their upper body off, by what it shows there
        (depth_people.close_sightings) when its colours are theirs (within ``close_gate`` of the
        signature they were identified by): a seated person close to the robot shows neither the
        Kinect's detector nor the laser's anything it can tell from furniture."""
        p = self.p.depth
        if p.close_range <= 0 or rgb is None:
            return
        tracks = [tr for tr in self.tracker.tracks
                  if tr.confirmed and tr.pid is not None and tr.last_kinect != t and tr.signature is not None
                  and tr.signatures >= self.tracker.params.appearance_after]
        if not tracks:
            return
        inverse = np.linalg.inv(base_in_fixed)
        in_base = np.array([tr.position for tr in tracks]) @ inverse[:2, :2].T + inverse[:2, 3]
        camera_xy = np.asarray(camera_in_base, float)[:2, 3]
        near = np.hypot(*(in_base - camera_xy).T) <= p.close_range
        if not near.any():
            return
        chosen = [tr for tr, n in zip(tracks, near, strict=True) if n]
        sightings = depth_people.close_sightings(depth, camera, camera_in_base, in_base[near], rgb, p)
        for track, seen in zip(chosen, sightings, strict=True):
            if seen is None or reid.distance(track.signature, seen.signature) > p.close_gate:
                continue
            x, y = base_in_fixed[:2, :2] @ (seen.x, seen.y) + base_in_fixed[:2, 3]
            self.tracker.hold(t, track, Detection(float(x), float(y), KINECT, KINECT_STD))
            self.counts["close up"] += 1

    def _note_clear_view(self, t, depth, camera, camera_in_base, base_in_fixed):
        """Tell the tracker which confirmed tracks the Kinect had in clear view in this frame."""
        tracks = [tr for tr in self.tracker.tracks if tr.confirmed]
        if not tracks:
            return
        inverse = np.linalg.inv(base_in_fixed)
        xy = np.array([tr.position for tr in tracks])
        in_base = xy @ inverse[:2, :2].T + inverse[:2, 3]
        clear = depth_people.in_clear_view(depth, camera, camera_in_base, in_base, self.p.depth)
        # where the Kinect may see a person's colours soon: in front of it, to its far limit and a
        # little beyond, also too near for the upper body to show yet
        coming = depth_people.in_clear_view(depth, camera, camera_in_base, in_base, self.p.depth, beyond=0.5,
                                            any_height=True)
        self.tracker.in_clear_view(t, [tr for tr, c in zip(tracks, clear, strict=True) if c],
                                   [tr for tr, c in zip(tracks, coming, strict=True) if c])

    def on_scan(self, t, ranges, angle_min, angle_increment, range_min, range_max, laser_in_fixed,
                fixed_in_map=None, track=True):
        """Fuse one scan taken at ``t`` [s]; returns the detections (fixed frame). ``track=False``
        (stopped): only the free-space memory learns from it."""
        pose = np.asarray(laser_in_fixed, float)
        if not track:
            ends, hit = laser_legs.beam_ends(ranges, angle_min, angle_increment, range_min, range_max, pose,
                                             self.p.free.max_range)
            self.free.update(t, pose[:2, 3], ends, hit)
            return []
        xy, valid = laser_legs.scan_points(ranges, angle_min, angle_increment, range_min, range_max, pose)
        sensor = pose[:2, 3]
        angle_max = angle_min + angle_increment * (len(ranges) - 1)
        # people behind the robot: the laser cannot see them, so not seeing them says nothing
        # (with hidden_timeout set; off by default)
        confirmed = [tr for tr in self.tracker.tracks if tr.confirmed]
        if confirmed and self.tracker.params.hidden_timeout > 0.0:
            coast = self.tracker.params.coast_limit
            seen = laser_legs.in_view([tr.output(coast) for tr in confirmed], angle_min, angle_max, pose)
            self.tracker.out_of_view(t, [tr for tr, s in zip(confirmed, seen, strict=True) if not s])
        self.tracker.hold_seated(t, xy[valid])  # a seated person's legs are one block, no pair of legs
        legs, widths = laser_legs.find_legs(xy, valid, sensor, self.p.legs, widths=True)
        keep = ~self._on_structure(legs, fixed_in_map)  # a wall's end is no leg
        legs, widths = legs[keep], widths[keep]
        leg_free = self.free.in_free_space(legs)
        # a leg in floor seen free lately (walking) and one that stands where beams always end (a
        # door frame's end, with no map) are not one person's
        people, members = laser_legs.pair_legs(legs, self.p.legs, members=True, groups=leg_free)
        free = [all(leg_free[k] for k in m) for m in members]
        lone = np.array([m[0] for m in members if len(m) == 1], dtype=int)
        # a lone leg whose partner something nearer may hide, or the end of the laser's view
        hidden, unseen = laser_legs.lone_partners(xy, valid, legs[lone], angle_min, angle_max, pose, self.p.legs)
        people = laser_legs.place_lone(people, members, widths, dict(zip(lone.tolist(), (hidden | unseen).tolist(),
                                                                         strict=True)), sensor, self.p.legs)
        hidden = dict(zip(lone.tolist(), hidden.tolist(), strict=True))
        dets = [Detection(float(x), float(y), LASER, LASER_STD, free=bool(f),
                          **_partly_hidden(len(m) == 1 and hidden[m[0]], x, y, sensor))
                for (x, y), f, m in zip(people, free, members, strict=True)]
        self.tracker.update(t, dets, LASER)
        self.counts[LASER] += len(dets)
        ends, hit = laser_legs.beam_ends(ranges, angle_min, angle_increment, range_min, range_max, pose,
                                         self.p.free.max_range)
        self.free.update(t, sensor, ends, hit)
        return dets

    def published(self):
        return self.tracker.published()
