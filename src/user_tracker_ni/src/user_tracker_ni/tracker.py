"""Multi-person tracker fusing Kinect and laser detections in a fixed frame (no ROS).

Each person is a :class:`Track`: a constant-velocity Kalman filter (kalman.py) plus its
bookkeeping. Detections arrive per sensor with their time; every call predicts the tracks
to that time, assigns detections to tracks by gated global nearest neighbour (scipy's
linear_sum_assignment), and updates. The cost of a pair is the Euclidean distance to the predicted
position [m], plus, for a Kinect detection with a colour signature and a track with one,
``appearance_weight`` [m] times their Bhattacharyya distance (0..1); a pair further apart than the
sensor's gate, or whose colours differ by more than ``appearance_gate`` once the track's colours
are known (``appearance_after`` signatures), is never made: where two people cross, the red shirt
keeps the red track. A track learns the colours of a detection only when no other confirmed
track is within ``signature_clearance``: two people close together may be one blob to the Kinect,
or one half hidden by the other, and a track that learnt a mixture would match both.

Life of a track:

- A Kinect detection (a person-shaped cluster of the depth image) that matches no track
  starts a *tentative* track; it is confirmed once ``confirm_hits`` of its first
  ``confirm_window`` Kinect frames detected it (M-of-N), and dropped when the window passes
  without that: clutter the detector takes for a person now and then never confirms.
- A laser detection (a pair of legs) that matches no track starts a tentative *laser* track:
  it is confirmed only once it has moved ``laser_confirm_distance`` from where it started, as a
  pair of walking legs does, and at least ``laser_free_hits`` of its detections, and most of them
  (``laser_free_share``), lay in floor the laser had seen free before (a person walks into free
  floor; a track hopping between chair legs or sliding along a wall never does). A pair of legs
  that stays put is confirmed too once ``laser_dwell_hits`` of its detections, and nearly all of
  them (``laser_dwell_free_share``), lay in floor seen free before: somebody walked there and
  stopped (a resident who halts in front of the robot before walking the confirming distance,
  too near for the Kinect to see their upper body). Furniture legs, walls and the legs of a
  person who stood there before the laser saw the floor never confirm by the laser alone (their
  cells end the laser's beams; such a person is confirmed by the Kinect and then kept by the
  laser). A walker's laser track that breaks up (her legs paired badly for a few scans, close to
  the robot) is carried on by the track that starts where it lost her (``laser_stitch_time``,
  :meth:`Tracker._stitch`): the pieces' walk counts together.
- A confirmed track is kept by either sensor: a person who leaves the Kinect's view (close up,
  or beside the robot) stays tracked while the laser sees their legs.
- A track no sensor has updated for ``timeout`` (confirmed) or ``tentative_timeout``
  (tentative) is dropped. Only time in a sensor's field of view counts for a confirmed track: one
  out of the laser's bearings (behind the robot: the caller says which, :meth:`Tracker.out_of_view`)
  is kept up to ``hidden_timeout`` (off by default) without an update, and once out of view for longer than
  ``timeout`` it stands where it was last going (the position it is published at). The robot that
  turns its back on a person waiting for it does not forget them (a person in a corridor, whom
  the robot forgot each time it turned away, made its plan flip between the corridor and a
  detour at every turn); once in view again, it is dropped after ``timeout`` without an update.
- Two confirmed tracks nearer than ``merge_distance`` going the same way are one person's (a leg
  each, say: no two people's centres are that close): the junior one goes (:meth:`Tracker._merge`).
- A detection on thin static structure of the robot's map (a wall, a door frame, a pole; the
  caller marks it) is nobody: it is not used at all (a person's centre is never inside a wall,
  and such a detection would drag a track onto it).
- What the Kinect does not see counts too: a confirmed track whose spot the Kinect had in clear
  view (the caller says which, :meth:`Tracker.in_clear_view`) without detecting a person there for
  ``unseen_timeout`` is dropped, whatever the laser says: a track the laser dragged onto a chair's
  legs, or a wall end, does not live on there.

Ids: on confirmation a track gets ``ni_id``, a fresh per-appearance number (as OpenNI's user
ids were), and ``pid``, the persistent id: the gallery's (reid.py) id whose signature matches
the track's colour signature and that no other track being seen holds (a track coasting unseen
for more than ``coast_limit`` gives its id up to a new track of the same colours), or a new one. A track
confirmed without a signature yet (seen by the laser only: a person walking in beside the robot)
waits for its first signature for ``id_wait`` out of the Kinect's view (in front of the Kinect,
also too near for it to show the upper body yet, the Kinect is about to see who it is: there it
waits up to ``id_wait_max``), then gets a *provisional* persistent id (a new one) so that it is
published; it is published only once it has an id. When the Kinect first sees
the colours of a track with a provisional id, the track is re-identified: it takes the stored
id its signature matches (one no other live track holds), and the provisional id, which never
had a signature, is forgotten; with no match the provisional id becomes its own.

Seated people (:attr:`Track.seat`): once ``seated_frames`` Kinect detections in a row said a track's
person sits (depth_people: her top seen below sitting_top) and her track is slower than
``facing_walk_speed``, the Kinect's place of her is her seat. The laser sees a seated person's shins
and feet in front of her (0.135 m in florence_sim for its user of build 0.9; 0.3-0.5 m for an adult
on a chair), and close up the Kinect sees her legs or her near side (close sightings): without the
seat, the track stood where her legs are, and the robot coming to her came that much too near. Those
keep her track alive but do not move it while they lie within ``seated_reach`` of the seat (less
than ``laser_gate``: her legs walking off must stay hers). A laser detection farther from the seat
(she got up and walked), or a Kinect detection of her standing, ends it; one whose top the image
cuts off ("unknown") says nothing of her posture, and its colours nothing of her: close up the
band the image keeps above her hips is her head's as much as her shirt's (a robot driving to the
seated user lost her track at 1.7 m, the new one had no seat and stood on her shins, 0.12 m nearer
the robot), so such a detection within ``seated_reach`` of the seat is hers whatever its colours,
and they are not learnt. Close to her, the laser's view of her legs is often no leg at all and the
Kinect loses her whenever the robot turns: while the scans show something within ``seated_reach``
of her seat, and the Kinect saw her within ``seat_hold``, her track is not dropped
(:meth:`Tracker.hold_seated`).

Facing (:attr:`Track.facing`): a person walking at ``facing_walk_speed`` or faster faces the way
they walk; a still one faces the way the Kinect's detections said (depth_people: a seated
person's shins in front of the torso), as the mean of their unit vectors, once
``facing_frames`` frames said it and they agree (the mean's length at least
``facing_agreement``); walking clears it (who sits down again may face elsewhere). Not while the
Kinect's last word on her posture was "standing" (:attr:`Track.stood`): close up, the image cuts a
standing person's top off (posture "unknown") and her legs under her torso read as shins
(bench/locator.py: standing users given facings 180 deg off, approach_me_map then went to their
backs); a seated person seen only close up keeps hers. Otherwise unknown (None).
"""

import collections
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from user_tracker_ni import reid
from user_tracker_ni.association import assign, distance_matrix
from user_tracker_ni.kalman import ConstantVelocity, along_and_across

KINECT, LASER = "kinect", "laser"
SEAT_POINTS = 3  # laser returns within seated_reach of a seat that show somebody there (hold_seated)


@dataclass(frozen=True)
class Detection:
    """One person seen by one sensor, in the fixed frame."""

    x: float  # [m]
    y: float  # [m]
    source: str  # KINECT or LASER
    std: float = 0.1  # [m] position standard deviation
    signature: np.ndarray | None = None  # colour signature (reid.signature), Kinect only
    free: bool | None = None  # laser only: in floor the laser saw free lately (free_space.py)
    on_structure: bool = False  # on thin static structure of the robot's map (static_map.py)
    facing: float | None = None  # [rad] which way the person faces, in the fixed frame (Kinect, seated people)
    posture: str | None = None  # Kinect: "sitting", "standing" or "unknown" (depth_people); None: not told
    # a person partly hidden (the Kinect's visible side, the laser's lone leg): the range is good, the side
    # is not. Standard deviation [m] across the line of sight, and that line's direction (x, y) from the
    # sensor in the fixed frame; std along it
    across_std: float | None = None
    sight: tuple | None = None

    @property
    def noise(self):
        """The measurement noise for the filter: std [m], or a 2x2 covariance [m^2] (across_std)."""
        if self.across_std is None or self.sight is None:
            return self.std
        return along_and_across(self.sight, self.std, self.across_std)

    @property
    def tells_velocity(self):
        """False for a partly hidden person: their detection moves the track's position, not its velocity."""
        return self.across_std is None


MERGE_SPEED = 0.3  # [m/s] tracks whose velocities differ by less may be merged (_merge): not crossing


@dataclass(frozen=True)
class TrackerParams:
    kinect_gate: float = 0.6  # [m] largest distance of a Kinect detection to a track it updates
    laser_gate: float = 0.4  # [m] the same for the laser's leg pairs
    confirm_hits: int = 3  # Kinect detections that confirm a Kinect-started track ...
    confirm_window: int = 5  # ... within its first this many Kinect frames
    laser_confirm_distance: float = 0.5  # [m] travel that confirms a laser-started track ...
    laser_free_hits: int = 5  # ... with at least this many of its detections in free floor ...
    laser_free_share: float = 0.6  # ... and at least this share of them (of its latest laser_free_window) ...
    laser_free_window: int = 20  # ... laser detections: the walk, not what the legs did before it ...
    laser_hit_share: float = 0.7  # ... this share of the scans since it started
    laser_dwell_hits: int = 10  # laser detections in free floor that confirm a laser-started track that stays put ...
    laser_dwell_free_share: float = 0.9  # ... when at least this share of its detections lay in free floor
    laser_stitch_time: float = 1.0  # [s] a laser track started where a tentative one lost its legs carries on its
    #                                walk, that tentative one dropped at most this long before (0: off)
    max_speed: float = 2.0  # [m/s] a tentative track takes no detection farther than this speed allows
    unseen_timeout: float = 1.0  # [s] a track in the Kinect's clear view it did not detect for this long is dropped
    coast_limit: float = 0.3  # [s] a published position extrapolates at most this long past the last update
    timeout: float = 1.0  # [s] a confirmed track no sensor updated for this long is dropped ...
    hidden_timeout: float = 0.0  # [s] ... but one out of the laser's view is kept this long (0: off, see the README)
    tentative_timeout: float = 0.6  # [s] the same for a tentative track
    merge_distance: float = 0.3  # [m] two confirmed tracks nearer than this are one person's: one goes (0: off)
    id_wait: float = 1.0  # [s] a confirmed track waits this long for a signature before a new id ...
    id_wait_max: float = 2.0  # [s] ... out of the Kinect's view; in front of it, this long at most
    process_noise: float = 1.0  # [m^2/s^3] white acceleration density of the filter
    appearance_weight: float = 0.5  # [m] cost of a colour difference of 1 (Bhattacharyya) in the assignment
    appearance_gate: float = 0.7  # largest colour difference of a Kinect detection and a track ...
    appearance_after: int = 5  # ... once the track has averaged this many signatures
    signature_clearance: float = 0.8  # [m] colours are learnt only with no other track this near
    reid_threshold: float = 0.4  # largest Bhattacharyya distance of a re-identification
    max_tracks: int = 30  # tentative tracks beyond this are not started (clutter storms)
    facing_walk_speed: float = 0.3  # [m/s] a person this fast faces the way they walk
    facing_frames: int = 3  # Kinect frames that told a still person's facing before it is published ...
    facing_agreement: float = 0.6  # ... and the length of the mean of their unit vectors (1: all agree)
    seated_frames: int = 2  # Kinect detections in a row of a person sitting that make her place her seat ...
    seated_reach: float = 0.3  # [m] ... and the laser's (or a close sighting's) within this do not move her (0: off)
    seat_hold: float = 10.0  # [s] a seated track the Kinect updated within this long is kept while the laser shows
    #                          something at her seat (hold_seated; 0: off)

    def validate(self):
        if not self.laser_stitch_time >= 0:
            raise ValueError(f"laser_stitch_time must be >= 0, got {self.laser_stitch_time}")
        for name in ("kinect_gate", "laser_gate", "laser_confirm_distance", "timeout", "tentative_timeout",
                     "process_noise", "unseen_timeout", "coast_limit"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not self.hidden_timeout >= 0:
            raise ValueError(f"hidden_timeout must be >= 0, got {self.hidden_timeout}")
        if not 1 <= self.confirm_hits <= self.confirm_window or self.max_tracks < 1 or not 0 <= self.id_wait \
                <= self.id_wait_max:
            raise ValueError("need 1 <= confirm_hits <= confirm_window, max_tracks >= 1, 0 <= id_wait <= id_wait_max")
        if self.laser_free_window < max(1, self.laser_free_hits):
            raise ValueError("need laser_free_window >= laser_free_hits and >= 1")
        if self.laser_free_hits < 0 or not 0 <= self.laser_free_share <= 1 or not 0 <= self.laser_hit_share <= 1:
            raise ValueError("need laser_free_hits >= 0, laser_free_share and laser_hit_share within 0..1")
        if self.laser_dwell_hits < 1 or not 0 <= self.laser_dwell_free_share <= 1:
            raise ValueError("need laser_dwell_hits >= 1 and laser_dwell_free_share within 0..1")
        if not self.max_speed > 0:
            raise ValueError(f"max_speed must be > 0, got {self.max_speed}")
        if self.appearance_weight < 0 or not 0 < self.appearance_gate <= 1 or self.appearance_after < 1:
            raise ValueError("need appearance_weight >= 0, 0 < appearance_gate <= 1, appearance_after >= 1")
        if not self.facing_walk_speed > 0 or self.facing_frames < 1 or not 0 <= self.facing_agreement <= 1:
            raise ValueError("need facing_walk_speed > 0, facing_frames >= 1 and 0 <= facing_agreement <= 1")
        if not self.merge_distance >= 0:
            raise ValueError(f"merge_distance must be >= 0, got {self.merge_distance}")
        if self.seated_frames < 1 or not 0 <= self.seated_reach < self.laser_gate:
            raise ValueError("need seated_frames >= 1 and 0 <= seated_reach < laser_gate (her legs walking off the "
                             "seat must still be within the laser's gate of her track)")
        if not 0 < self.reid_threshold <= 1:
            raise ValueError(f"reid_threshold must be in (0, 1], got {self.reid_threshold}")
        if not self.seat_hold >= 0:
            raise ValueError(f"seat_hold must be >= 0, got {self.seat_hold}")
        return self


@dataclass
class Track:
    filter: ConstantVelocity
    origin: str  # the sensor that started it
    created: float  # [s]
    last_update: float  # [s] any sensor
    start: tuple  # (x, y) [m] where it started
    last_kinect: float | None = None  # [s]
    unseen_since: float | None = None  # [s] in the Kinect's clear view, not detected, since
    hidden_at: float | None = None  # [s] the latest reading at which it was out of the laser's view
    standing: bool = False  # out of view past ``timeout``: held still where it was last going
    last_laser: float | None = None  # [s]
    kinect_hits: int = 0
    laser_hits: int = 0
    free_hits: int = 0  # laser detections in free floor
    recent_free: collections.deque = field(default_factory=collections.deque)  # free or not: the latest laser hits
    kinect_frames: int = 0  # Kinect frames since it started (while tentative)
    laser_frames: int = 0  # scans since it started (while tentative)
    travelled: float = 0.0  # [m] largest distance from the start
    hit_frames: int = 0  # laser_frames at its latest laser detection
    stitched: bool = False  # it carries on the walk of a tentative laser track dropped (Tracker._stitch)
    confirmed_at: float | None = None  # [s]
    id_wait_from: float | None = None  # [s] the wait for a signature (id_wait) counts from here
    ni_id: int | None = None
    pid: int | None = None
    provisional: bool = False  # pid was given without a signature: re-identified at the first one
    signature: np.ndarray | None = None  # this appearance's mean signature
    signatures: int = 0
    sources: set = field(default_factory=set)  # sensors that updated it since the last publication
    updated: tuple | None = None  # ((x, y), (vx, vy)) just after the last update
    superseded: bool = False  # a newer track of the same person took its persistent id over
    facing_sum: np.ndarray = field(default_factory=lambda: np.zeros(2))  # sum of the facings' unit vectors ...
    facing_count: int = 0  # ... and how many, since the person last walked
    sitting_count: int = 0  # Kinect detections in a row that said the person sits
    stood: bool = False  # the Kinect's last word on her posture (sitting or standing) was standing
    seat: tuple | None = None  # (x, y) [m] where the Kinect placed her sitting (module docstring), None: not seated
    held_at: float | None = None  # [s] the latest scan that showed something at her seat (Tracker.hold_seated)

    @property
    def confirmed(self):
        return self.confirmed_at is not None

    @property
    def position(self):
        """Where the filter predicts the person now [m] (for association)."""
        return self.filter.position

    def output(self, coast_limit):
        """(x, y) [m] to publish: the filter's estimate, but no more than ``coast_limit`` [s] of
        extrapolation past the last update (a track coasting on an old velocity would walk through
        walls)."""
        late = self.filter.t - self.last_update
        if late <= coast_limit or self.updated is None:
            return self.position
        (x, y), (vx, vy) = self.updated
        return x + vx * coast_limit, y + vy * coast_limit

    @property
    def velocity(self):
        return self.filter.velocity

    def still(self, params):
        """Whether the track is slower than ``facing_walk_speed`` (not walking: nobody walks seated)."""
        return math.hypot(*self.velocity) < params.facing_walk_speed

    def seated(self, params):
        """Whether the person sits: the Kinect's last ``seated_frames`` detections of her said so (no
        standing one since) and her track is still."""
        return self.sitting_count >= params.seated_frames and self.still(params)

    def facing(self, params):
        """Which way [rad] the person faces in the fixed frame, or None (module docstring)."""
        if not self.still(params):
            return math.atan2(self.velocity[1], self.velocity[0])
        if self.facing_count < params.facing_frames or self.stood:
            return None
        if float(np.hypot(*self.facing_sum)) < params.facing_agreement * self.facing_count:
            return None
        return math.atan2(self.facing_sum[1], self.facing_sum[0])


class Tracker:
    def __init__(self, params=None):
        self.params = (params or TrackerParams()).validate()
        self.gallery = reid.Gallery(self.params.reid_threshold)
        self.tracks = []
        self._ni_ids = itertools.count(1)
        self.dropped = collections.Counter()  # confirmed tracks dropped, by reason (diagnostics)
        self._lost = []  # (dropped at [s], track): tentative laser tracks dropped lately (_stitch)

    # --- public -----------------------------------------------------------------------------------
    def reset(self):
        """Forget every track (Stop): persistent ids and their signatures are kept."""
        self.tracks = []
        self._lost = []

    def update(self, t, detections, source):
        """Fuse the detections of one sensor reading taken at time ``t`` [s]."""
        dets = [d for d in detections if np.isfinite(d.x) and np.isfinite(d.y) and not d.on_structure]
        for track in self.tracks:
            track.filter.predict(t)
            if not track.confirmed:
                if source == KINECT:
                    track.kinect_frames += 1
                else:
                    track.laser_frames += 1
        gate = self.params.kinect_gate if source == KINECT else self.params.laser_gate
        if source == LASER:
            dets = self._unambiguous(dets, gate)
        free = list(range(len(dets)))
        # confirmed tracks choose first: a tentative track (table legs, say) never takes a detection
        # that a confirmed person's track wants
        for group in ([tr for tr in self.tracks if tr.confirmed], [tr for tr in self.tracks if not tr.confirmed]):
            if not group or not free:
                continue
            cost = self._cost(group, [dets[j] for j in free], gate, t)
            pairs, _, left = assign(cost, np.inf)
            for row, col in pairs:
                self._apply(group[row], dets[free[col]], t, source)
            free = [free[col] for col in left]
        for j in free:
            if len(self.tracks) < self.params.max_tracks:
                self._start(dets[j], t, source)
        self._maintain(t)

    def hold(self, t, track, det):
        """Update ``track`` (of self.tracks) with a detection the caller made for it alone at time
        ``t``, after :meth:`update` of that reading: the Kinect's close sighting of that person
        (pipeline.py). It keeps the track and its place; its colours are not learnt (the
        sighting's band is not the shirt's band the signature was learnt from) and it counts
        toward no confirmation."""
        if not (np.isfinite(det.x) and np.isfinite(det.y)) or det.on_structure:
            return
        track.filter.predict(t)
        if not self._at_seat(track, det):
            track.filter.update((det.x, det.y), det.noise, det.tells_velocity)
        track.last_update = t
        track.updated = (track.position, track.velocity)
        track.standing = False
        track.sources.add(det.source)
        if det.source == KINECT:
            track.last_kinect = t
        else:
            track.last_laser = t

    def in_clear_view(self, t, tracks, in_view=None):
        """After the Kinect frame of time ``t``: ``tracks`` (of self.tracks) were in its clear view
        (in the image, in range, nothing in front). Those it did not detect start, or go on,
        counting toward ``unseen_timeout``; every other track's count is reset. ``in_view`` (by
        default ``tracks``): the tracks whose colours the Kinect may see soon (to the end of its
        range): those without a persistent id wait for them instead of taking a provisional one."""
        clear = {id(tr) for tr in tracks}
        coming = clear if in_view is None else {id(tr) for tr in in_view}
        kept = []
        for track in self.tracks:
            if track.confirmed and track.pid is None and id(track) in coming:
                track.id_wait_from = t  # the Kinect will see who it is in a moment: no provisional id yet
            if not track.confirmed or id(track) not in clear or track.last_kinect == t:
                track.unseen_since = None
            elif track.unseen_since is None:
                track.unseen_since = t
            if track.unseen_since is None or t - track.unseen_since < self.params.unseen_timeout:
                kept.append(track)
            else:
                self.dropped["in the Kinect's clear view, not detected"] += 1
        self.tracks = kept

    def hold_seated(self, t, points):
        """After a scan at ``t`` [s] whose returns are ``points`` [N, 2] (fixed frame): a seated track
        (with a seat) the Kinect updated within ``seat_hold`` is not dropped for want of updates while
        at least SEAT_POINTS of them lie within ``seated_reach`` of her seat; it is not moved. Close
        to a seated person, the laser sees her lower legs as one block that is no pair of legs, and the
        Kinect loses her whenever the robot turns: her track was dropped within a second, and the next
        one, on her legs without a seat, stood 0.12-0.17 m from her centre (from her back, beyond it:
        make demo's robot, turning beside a seated user for a minute, ended 0.39 m from her with the
        tracker saying 0.54 m). Bounded by ``seat_hold`` since the Kinect last saw her: a chair left
        behind does not keep her for good."""
        p = self.params
        if p.seat_hold <= 0 or p.seated_reach <= 0:
            return
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        for track in self.tracks:
            if track.seat is None or not track.confirmed or track.last_kinect is None \
                    or t - track.last_kinect > p.seat_hold:
                continue
            near = np.hypot(pts[:, 0] - track.seat[0], pts[:, 1] - track.seat[1]) <= p.seated_reach
            if int(np.count_nonzero(near)) >= SEAT_POINTS:
                track.held_at = t

    def out_of_view(self, t, tracks):
        """At the reading of time ``t``: ``tracks`` (of self.tracks) lay outside the laser's field
        of view (its bearings): their time without an update does not count. A confirmed one out
        of view for more than ``timeout`` since its last update stands still where it is published."""
        p = self.params
        if p.hidden_timeout <= 0.0:
            return
        for track in tracks:
            if not track.confirmed:
                continue
            track.hidden_at = t
            if not track.standing and t - track.last_update > p.timeout:
                track.filter.predict(t)
                track.filter.stand(*track.output(p.coast_limit))
                track.standing = True

    def published(self):
        """Confirmed tracks that have a persistent id, by persistent id."""
        return sorted((tr for tr in self.tracks if tr.confirmed and tr.pid is not None and not tr.superseded),
                      key=lambda tr: tr.pid)

    def people(self):
        """Every confirmed track, identified or not (``pid`` None while it waits for its colours), by
        ``ni_id``: where people are, for costmaps and safety, where who it is does not matter."""
        return sorted((tr for tr in self.tracks if tr.confirmed and not tr.superseded), key=lambda tr: tr.ni_id)

    # --- internals --------------------------------------------------------------------------------------
    def _unambiguous(self, dets, gate):
        """Leg pairs within the gate of one confirmed track at most: where two people are close (they
        cross, or walk side by side), a pair may hold a leg of each, and with no colour to tell them
        apart it would drag one track onto the other; the Kinect's detections carry those tracks."""
        confirmed = [tr.position for tr in self.tracks if tr.confirmed]
        if len(confirmed) < 2 or not dets:
            return dets
        near = distance_matrix(confirmed, [(d.x, d.y) for d in dets]) < gate
        return [d for d, n in zip(dets, near.sum(axis=0), strict=True) if n < 2]

    def _cost(self, tracks, dets, gate, t):
        """Assignment costs [len(tracks), len(dets)] (inf: never) of distance and colour; a tentative
        track's gate is also what ``max_speed`` allows since its last update (plus 0.1 m of noise),
        so that it cannot hop from one chair leg to the next."""
        p = self.params
        cost = distance_matrix([tr.position for tr in tracks], [(d.x, d.y) for d in dets])
        gates = np.array([gate if tr.confirmed else min(gate, 0.1 + p.max_speed * (t - tr.last_update))
                          for tr in tracks])
        cost[cost >= gates[:, None]] = np.inf
        for j, det in enumerate(dets):
            if det.signature is None:
                continue
            for i, tr in enumerate(tracks):
                if tr.signature is None or not np.isfinite(cost[i, j]) or self._cut_at_seat(tr, det):
                    continue
                a = reid.distance(tr.signature, det.signature)
                if a > p.appearance_gate and tr.signatures >= p.appearance_after:
                    cost[i, j] = np.inf
                else:
                    cost[i, j] += p.appearance_weight * a
        return cost

    def _start(self, det, t, source):
        kf = ConstantVelocity(det.x, det.y, t, pos_std=max(det.std, det.across_std or 0.0), q=self.params.process_noise)
        track = Track(kf, source, t, t, (det.x, det.y), kinect_frames=int(source == KINECT),
                      laser_frames=int(source == LASER),
                      recent_free=collections.deque(maxlen=self.params.laser_free_window))
        self._record(track, det, t, source)
        self.tracks.append(track)
        self._maybe_confirm(track, t)

    def _apply(self, track, det, t, source):
        if not (source == LASER and self._at_seat(track, det)):
            track.filter.update((det.x, det.y), det.noise, det.tells_velocity)
        self._record(track, det, t, source)
        self._maybe_confirm(track, t)

    def _at_seat(self, track, det):
        """Whether ``det`` (the laser's, or a close sighting) is a seated person's legs: within
        seated_reach of her seat. Then her track stands at the seat; farther, she is not seated any
        more (module docstring)."""
        if track.seat is None:
            return False
        if self._near_seat(track, det):
            x, y = track.seat
            track.filter.stand(x, y, vel_std=0.1)
            return True
        track.seat, track.sitting_count = None, 0
        return False

    def _cut_at_seat(self, track, det):
        """Whether ``det`` is the Kinect's view of a seated person, her top cut off by the image
        (posture "unknown"), at her seat: the colours of such a view are not her shirt's (the band
        below the image's top row holds her head; module docstring), so they neither gate nor teach."""
        return det.source == KINECT and det.posture == "unknown" and self._near_seat(track, det)

    def _near_seat(self, track, det):
        """Whether ``det`` lies within seated_reach of ``track``'s seat (False without one)."""
        return track.seat is not None and \
            float(np.hypot(det.x - track.seat[0], det.y - track.seat[1])) <= self.params.seated_reach

    def _crowded(self, track, det):
        """Another track within ``signature_clearance`` of the detection: the Kinect may have seen
        the two people as one, or one half hidden by the other, so its colours are not learnt."""
        r = self.params.signature_clearance
        return any(other is not track and np.hypot(other.position[0] - det.x, other.position[1] - det.y) < r
                   for other in self.tracks if other.confirmed)

    def _record(self, track, det, t, source):
        track.last_update = t
        track.standing = False
        track.updated = (track.position, track.velocity)
        track.sources.add(source)
        x, y = track.position
        track.travelled = max(track.travelled, float(np.hypot(x - track.start[0], y - track.start[1])))
        if not track.still(self.params):  # walking clears what the Kinect said of her facing
            track.facing_sum, track.facing_count = np.zeros(2), 0
        if source == KINECT:
            track.last_kinect = t
            track.kinect_hits += 1
            if det.posture == "sitting":
                track.sitting_count += 1
                track.stood = False
                if not track.still(self.params):
                    track.seat = None
                elif track.sitting_count >= self.params.seated_frames and self.params.seated_reach > 0:
                    track.seat = tuple(float(v) for v in track.position)
            elif det.posture == "standing":  # "unknown" (her top cut off by the image) says nothing
                track.sitting_count, track.seat, track.stood = 0, None, True
            if det.facing is not None and math.isfinite(det.facing):
                track.facing_sum = track.facing_sum + np.array([math.cos(det.facing), math.sin(det.facing)])
                track.facing_count += 1
            if det.signature is not None and not self._crowded(track, det) and not self._cut_at_seat(track, det):
                track.signatures += 1
                track.signature = det.signature if track.signature is None else \
                    reid.blend(track.signature, det.signature, max(1.0 / track.signatures, 0.05))
                if track.provisional:
                    self._reidentify(track)
                if track.pid is not None:
                    self.gallery.update(track.pid, det.signature)
        else:
            track.last_laser = t
            track.laser_hits += 1
            track.hit_frames = track.laser_frames
            track.free_hits += int(bool(det.free))
            track.recent_free.append(bool(det.free))

    def _maybe_confirm(self, track, t):
        p = self.params
        if not track.confirmed:
            by_kinect = track.kinect_hits >= p.confirm_hits
            seen = track.origin == LASER and track.laser_hits >= p.laser_hit_share * track.laser_frames
            recent = sum(track.recent_free)
            walked = (track.travelled >= p.laser_confirm_distance and recent >= p.laser_free_hits
                      and recent >= p.laser_free_share * len(track.recent_free))
            stopped = track.free_hits >= p.laser_dwell_hits and track.free_hits >= p.laser_dwell_free_share \
                * track.laser_hits
            if by_kinect or (seen and (walked or stopped)):
                track.confirmed_at = track.id_wait_from = t
                track.ni_id = next(self._ni_ids)
        if track.confirmed and track.pid is None:
            if track.signature is not None:
                pid, _ = self.gallery.identify(track.signature, exclude=self._held(track, t))
                if pid is not None:
                    self._take_over(pid, track)
                track.pid = pid if pid is not None else self.gallery.enroll(track.signature)
            elif t - track.id_wait_from >= p.id_wait or t - track.confirmed_at >= p.id_wait_max:
                track.pid = self.gallery.enroll(None)
                track.provisional = True

    def _held(self, track, t):
        """Persistent ids a new track cannot take: those of the other tracks that are still being
        seen. A track coasting unseen for longer than ``coast_limit`` has lost its person: a new
        track whose colours are that person's takes the id over (the person turned where the
        coasting track went straight on)."""
        limit = self.params.coast_limit
        return {tr.pid for tr in self.tracks
                if tr is not track and tr.pid is not None and not tr.superseded and t - tr.last_update <= limit}

    def _take_over(self, pid, track):
        """``track`` takes ``pid`` over from a coasting track that holds it (if any), which ends."""
        for other in self.tracks:
            if other is not track and other.pid == pid:
                other.superseded = True

    def _reidentify(self, track):
        """The first signature of a track with a provisional id: take the stored id it matches."""
        pid, _ = self.gallery.identify(track.signature, exclude=self._held(track, track.last_update) | {track.pid})
        if pid is not None:
            self._take_over(pid, track)
            self.gallery.forget(track.pid)
            track.pid = pid
        track.provisional = False

    def _maintain(self, t):
        p = self.params
        kept = []
        for track in self.tracks:
            limit = p.timeout if track.confirmed else p.tentative_timeout
            failed = not track.confirmed and track.origin == KINECT and track.kinect_frames >= p.confirm_window
            # time out of the laser's view does not count, up to hidden_timeout
            since = track.last_update if track.hidden_at is None else max(track.last_update, track.hidden_at)
            if track.held_at is not None and track.seat is not None:
                since = max(since, track.held_at)  # a seated person the laser still shows at her seat
            fresh = t - since <= limit and (track.hidden_at is None or t - track.last_update <= p.hidden_timeout)
            if fresh and not failed and not track.superseded:
                kept.append(track)
                self._maybe_confirm(track, t)
            elif track.confirmed and not fresh:
                self.dropped["no update"] += 1
            elif (not fresh and track.origin == LASER and p.laser_stitch_time > 0 and track.free_hits > 0
                  and track.laser_hits >= p.laser_hit_share * track.hit_frames):
                self._lost.append((t, track))  # a walker's, maybe: seen steadily, in free floor at times
        self.tracks = [tr for tr in kept if not tr.superseded]
        self._merge()
        self._stitch(t)

    def _merge(self):
        """Two confirmed tracks nearer than ``merge_distance``, going the same way (their velocities
        differ by less than MERGE_SPEED), are one person's (two people's centres are farther apart
        than that; two walkers' predictions may pass closer as they cross): the junior one goes.
        Offline, a person who walked on ahead of the robot along the corridor and stopped 1.0-1.2 m
        in front of it became two confirmed tracks 0.17 m apart, one on each leg (a second confirmed
        track came within 0.3 m of hers in 12 of 18 such runs: seeds 1-3, two places); every leg pair
        then lies within the laser's gate of both, and :meth:`_unambiguous` gives it to neither, so
        both starve while the Kinect cannot see her upper body. Senior: the one with
        a persistent id that is not provisional, then the one with any id, then the one confirmed
        first; the junior's provisional id is forgotten."""
        d = self.params.merge_distance
        confirmed = [tr for tr in self.tracks if tr.confirmed]
        if d <= 0 or len(confirmed) < 2:
            return
        def seniority(tr):
            return (tr.pid is not None and not tr.provisional, tr.pid is not None, -tr.confirmed_at)
        for a, b in itertools.combinations(confirmed, 2):
            if a.superseded or b.superseded or math.dist(a.position, b.position) >= d or \
                    math.dist(a.velocity, b.velocity) >= MERGE_SPEED:
                continue
            junior = min((a, b), key=seniority)
            junior.superseded = True
            if junior.pid is not None and junior.provisional:
                self.gallery.forget(junior.pid)
            self.dropped["merged into a nearer track (one person's)"] += 1
        self.tracks = [tr for tr in self.tracks if not tr.superseded]

    def _stitch(self, t):
        """A walker's laser track breaks up close to the robot: for a few scans her legs pair badly
        (one leg alone, two detections of one person, a chair's leg between them), a new tentative
        track takes her next detections and the old one is dropped. Neither walked
        ``laser_confirm_distance`` alone, and once she stops the floor under her feet is no longer
        free, so the track that ends with her standing never confirms (florence_sim: the day's user,
        up from her seat 0.5 m from the robot and 0.8 m on, stood unconfirmed at 1.05 m, where the
        Kinect does not see her upper body, in 2 of 11 tries). So a tentative laser track started
        within ``laser_gate`` of where a dropped tentative laser track last had legs, after it last
        did and at most ``laser_stitch_time`` after it was dropped, carries on its walk: its start,
        its hits, its free hits and its scans up to its last hit (the scans between, her legs went
        to the wrong track). Only a track that may have been a walker's hands its walk on: one seen
        in ``laser_hit_share`` of its scans up to its last hit, in free floor at least once (the
        legs of the seated user among her chair's, seen now and then, made a chain of tracks from
        her seat whose hit share then held her walk unconfirmed: 2 of 6 tries). Chair legs chained
        this way still never lay in free floor."""
        p = self.params
        self._lost = [(at, old) for at, old in self._lost if t - at <= p.laser_stitch_time]
        if not self._lost:
            return
        for track in self.tracks:
            if (not self._lost or track.confirmed or track.stitched or track.origin != LASER
                    or t - track.created > p.laser_stitch_time):
                continue
            near = [(float(np.hypot(track.start[0] - old.updated[0][0], track.start[1] - old.updated[0][1])), k)
                    for k, (_, old) in enumerate(self._lost)
                    if old.updated is not None and old.last_update < track.created]
            near = [(d, k) for d, k in near if d <= p.laser_gate]
            if not near:
                continue
            _, old = self._lost.pop(min(near)[1])
            x, y = track.position
            track.start, track.stitched = old.start, True
            track.travelled = max(track.travelled, old.travelled, float(np.hypot(x - old.start[0], y - old.start[1])))
            track.laser_hits += old.laser_hits
            track.free_hits += old.free_hits
            track.recent_free = collections.deque([*old.recent_free, *track.recent_free], maxlen=p.laser_free_window)
            track.laser_frames += old.hit_frames
            self._maybe_confirm(track, t)
