"""Multi-person tracker fusing Kinect and laser detections in a fixed frame (no ROS).

Each person is a :class:`Track`: a constant-velocity Kalman filter (kalman.py) plus its
bookkeeping. Detections arrive per sensor with their time; every call predicts the tracks
to that time, assigns detections to tracks by gated global nearest neighbour (Euclidean
distance to the predicted position, scipy's linear_sum_assignment), and updates.

Life of a track:

- A Kinect detection (a person-shaped cluster of the depth image) that matches no track
  starts a *tentative* track; it is confirmed once ``confirm_hits`` of its first
  ``confirm_window`` Kinect frames detected it (M-of-N), and dropped when the window passes
  without that: clutter the detector takes for a person now and then never confirms.
- A laser detection (a pair of legs) that matches no track starts a tentative *laser* track:
  it is confirmed only once it has moved ``laser_confirm_distance`` from where it started, as a
  pair of walking legs does; furniture legs, walls and a still person's legs never confirm by
  the laser alone (a still person is confirmed by the Kinect and then kept by the laser).
- A confirmed track is kept by either sensor: a person who leaves the Kinect's view (close up,
  or beside the robot) stays tracked while the laser sees their legs.
- A track no sensor has updated for ``timeout`` (confirmed) or ``tentative_timeout``
  (tentative) is dropped.

Ids: on confirmation a track gets ``ni_id``, a fresh per-appearance number (as OpenNI's user
ids were), and ``pid``, the persistent id: the gallery's (reid.py) id whose signature matches
the track's colour signature and that no other live track holds, or a new one. A track
confirmed without a signature yet (seen by the laser only: a person walking in beside the robot)
waits up to ``id_wait`` for its first signature, then gets a *provisional* persistent id (a new
one) so that it is published; it is published only once it has an id. When the Kinect first sees
the colours of a track with a provisional id, the track is re-identified: it takes the stored
id its signature matches (one no other live track holds), and the provisional id, which never
had a signature, is forgotten; with no match the provisional id becomes its own.
"""

import itertools
from dataclasses import dataclass, field

import numpy as np

from user_tracker_ni import reid
from user_tracker_ni.association import assign, distance_matrix
from user_tracker_ni.kalman import ConstantVelocity

KINECT, LASER = "kinect", "laser"


@dataclass(frozen=True)
class Detection:
    """One person seen by one sensor, in the fixed frame."""

    x: float  # [m]
    y: float  # [m]
    source: str  # KINECT or LASER
    std: float = 0.1  # [m] position standard deviation
    signature: np.ndarray | None = None  # colour signature (reid.signature), Kinect only


@dataclass(frozen=True)
class TrackerParams:
    kinect_gate: float = 0.6  # [m] largest distance of a Kinect detection to a track it updates
    laser_gate: float = 0.4  # [m] the same for the laser's leg pairs
    confirm_hits: int = 3  # Kinect detections that confirm a Kinect-started track ...
    confirm_window: int = 5  # ... within its first this many Kinect frames
    laser_confirm_distance: float = 0.5  # [m] travel that confirms a laser-started track
    timeout: float = 1.0  # [s] a confirmed track no sensor updated for this long is dropped
    tentative_timeout: float = 0.6  # [s] the same for a tentative track
    id_wait: float = 1.0  # [s] a confirmed track waits this long for a signature before a new id
    process_noise: float = 1.0  # [m^2/s^3] white acceleration density of the filter
    reid_threshold: float = 0.4  # largest Bhattacharyya distance of a re-identification
    max_tracks: int = 30  # tentative tracks beyond this are not started (clutter storms)

    def validate(self):
        for name in ("kinect_gate", "laser_gate", "laser_confirm_distance", "timeout", "tentative_timeout",
                     "process_noise"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 1 <= self.confirm_hits <= self.confirm_window or self.max_tracks < 1 or self.id_wait < 0:
            raise ValueError("need 1 <= confirm_hits <= confirm_window, max_tracks >= 1, id_wait >= 0")
        if not 0 < self.reid_threshold <= 1:
            raise ValueError(f"reid_threshold must be in (0, 1], got {self.reid_threshold}")
        return self


@dataclass
class Track:
    filter: ConstantVelocity
    origin: str  # the sensor that started it
    created: float  # [s]
    last_update: float  # [s] any sensor
    start: tuple  # (x, y) [m] where it started
    last_kinect: float | None = None  # [s]
    last_laser: float | None = None  # [s]
    kinect_hits: int = 0
    kinect_frames: int = 0  # Kinect frames since it started (while tentative)
    travelled: float = 0.0  # [m] largest distance from the start
    confirmed_at: float | None = None  # [s]
    ni_id: int | None = None
    pid: int | None = None
    provisional: bool = False  # pid was given without a signature: re-identified at the first one
    signature: np.ndarray | None = None  # this appearance's mean signature
    signatures: int = 0
    sources: set = field(default_factory=set)  # sensors that updated it since the last publication

    @property
    def confirmed(self):
        return self.confirmed_at is not None

    @property
    def position(self):
        return self.filter.position

    @property
    def velocity(self):
        return self.filter.velocity


class Tracker:
    def __init__(self, params=None):
        self.params = (params or TrackerParams()).validate()
        self.gallery = reid.Gallery(self.params.reid_threshold)
        self.tracks = []
        self._ni_ids = itertools.count(1)

    # --- public -----------------------------------------------------------------------------------
    def reset(self):
        """Forget every track (Stop): persistent ids and their signatures are kept."""
        self.tracks = []

    def update(self, t, detections, source):
        """Fuse the detections of one sensor reading taken at time ``t`` [s]."""
        dets = [d for d in detections if np.isfinite(d.x) and np.isfinite(d.y)]
        for track in self.tracks:
            track.filter.predict(t)
            if source == KINECT and not track.confirmed:
                track.kinect_frames += 1
        gate = self.params.kinect_gate if source == KINECT else self.params.laser_gate
        free = list(range(len(dets)))
        # confirmed tracks choose first: a tentative track (table legs, say) never takes a detection
        # that a confirmed person's track wants
        for group in ([tr for tr in self.tracks if tr.confirmed], [tr for tr in self.tracks if not tr.confirmed]):
            if not group or not free:
                continue
            cost = distance_matrix([tr.position for tr in group], [(dets[j].x, dets[j].y) for j in free])
            pairs, _, left = assign(cost, gate)
            for row, col in pairs:
                self._apply(group[row], dets[free[col]], t, source)
            free = [free[col] for col in left]
        for j in free:
            if len(self.tracks) < self.params.max_tracks:
                self._start(dets[j], t, source)
        self._maintain(t)

    def published(self):
        """Confirmed tracks that have a persistent id, by persistent id."""
        return sorted((tr for tr in self.tracks if tr.confirmed and tr.pid is not None), key=lambda tr: tr.pid)

    # --- internals --------------------------------------------------------------------------------------
    def _start(self, det, t, source):
        kf = ConstantVelocity(det.x, det.y, t, pos_std=det.std, q=self.params.process_noise)
        track = Track(kf, source, t, t, (det.x, det.y), kinect_frames=int(source == KINECT))
        self._record(track, det, t, source)
        self.tracks.append(track)
        self._maybe_confirm(track, t)

    def _apply(self, track, det, t, source):
        track.filter.update((det.x, det.y), det.std)
        self._record(track, det, t, source)
        self._maybe_confirm(track, t)

    def _record(self, track, det, t, source):
        track.last_update = t
        track.sources.add(source)
        x, y = track.position
        track.travelled = max(track.travelled, float(np.hypot(x - track.start[0], y - track.start[1])))
        if source == KINECT:
            track.last_kinect = t
            track.kinect_hits += 1
            if det.signature is not None:
                track.signatures += 1
                track.signature = det.signature if track.signature is None else \
                    reid.blend(track.signature, det.signature, max(1.0 / track.signatures, 0.05))
                if track.provisional:
                    self._reidentify(track)
                if track.pid is not None:
                    self.gallery.update(track.pid, det.signature)
        else:
            track.last_laser = t

    def _maybe_confirm(self, track, t):
        p = self.params
        if not track.confirmed:
            by_kinect = track.kinect_hits >= p.confirm_hits
            by_laser = track.origin == LASER and track.travelled >= p.laser_confirm_distance
            if by_kinect or by_laser:
                track.confirmed_at = t
                track.ni_id = next(self._ni_ids)
        if track.confirmed and track.pid is None:
            held = {tr.pid for tr in self.tracks if tr.pid is not None}
            if track.signature is not None:
                pid, _ = self.gallery.identify(track.signature, exclude=held)
                track.pid = pid if pid is not None else self.gallery.enroll(track.signature)
            elif t - track.confirmed_at >= p.id_wait:
                track.pid = self.gallery.enroll(None)
                track.provisional = True

    def _reidentify(self, track):
        """The first signature of a track with a provisional id: take the stored id it matches."""
        held = {tr.pid for tr in self.tracks if tr is not track and tr.pid is not None}
        pid, _ = self.gallery.identify(track.signature, exclude=held | {track.pid})
        if pid is not None:
            self.gallery.forget(track.pid)
            track.pid = pid
        track.provisional = False

    def _maintain(self, t):
        p = self.params
        kept = []
        for track in self.tracks:
            limit = p.timeout if track.confirmed else p.tentative_timeout
            failed = not track.confirmed and track.origin == KINECT and track.kinect_frames >= p.confirm_window
            if t - track.last_update <= limit and not failed:
                kept.append(track)
                self._maybe_confirm(track, t)
        self.tracks = kept
