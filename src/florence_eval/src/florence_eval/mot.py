"""CLEAR MOT metrics of a people tracker against ground truth (Bernardin & Stiefelhagen 2008;
no ROS).

Frame by frame, ground-truth objects and hypotheses (tracks) are matched within ``gate`` [m]:
a pair matched in the previous frame stays matched while it is within the gate; the others are
matched by minimum total distance (Hungarian). Then:

- a *miss* is a ground-truth object with no hypothesis, a *false positive* a hypothesis with no
  object;
- an *id switch* is an object matched to another hypothesis id than the one it was last matched
  to (however long ago: a person who comes back under a new persistent id counts);
- MOTA = 1 - (misses + false positives + switches) / ground-truth objects; MOTP = mean distance
  [m] of the matches.

Objects outside the region of interest (``care``: for example within 0.8-4 m and in the Kinect's
view) are matched like the others, so that their tracks do not count as false positives, but
neither they nor their matches enter the counts; in particular the hypothesis an object was last
matched to, for the id switches, is the last one *inside* the region (a tracker may carry a person
under a provisional id while they are out of view). Likewise a hypothesis outside the region
(``hyp_care``) matched to nothing is not a false positive; every unmatched hypothesis, inside the
region or not, is counted apart (``unmatched_anywhere``: ghost tracks behind the robot say).
"""

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

LOG_LIMIT = 100  # misses and false positives logged (for a report: when and where)


@dataclass
class MotAccumulator:
    gate: float = 0.5  # [m]
    frames: int = 0
    objects: int = 0  # ground-truth objects counted (in the region of interest)
    matches: int = 0
    misses: int = 0
    false_positives: int = 0
    switches: int = 0
    unmatched_anywhere: int = 0  # unmatched hypotheses, inside the region of interest or not
    distance_sum: float = 0.0  # [m] over the counted matches
    switch_log: list = field(default_factory=list)  # (time, object id, old hypothesis id, new one)
    miss_log: list = field(default_factory=list)  # (time, object id) of the first LOG_LIMIT misses
    false_positive_log: list = field(default_factory=list)  # (time, hypothesis id, (x, y)) likewise
    _previous: dict = field(default_factory=dict)  # object id -> hypothesis id matched last frame
    _last: dict = field(default_factory=dict)  # object id -> hypothesis id matched last (ever)

    def update(self, t, objects, hypotheses, care=None, hyp_care=None):
        """One frame at time ``t``. objects: {id: (x, y)}; hypotheses: {id: (x, y)}; care: {object id:
        bool}, whether the object counts (all count when None); hyp_care: {hypothesis id: bool},
        whether an unmatched hypothesis is a false positive (all are when None). Returns {object id:
        hypothesis id} of this frame's matches."""
        self.frames += 1
        o_ids, h_ids = list(objects), list(hypotheses)
        o_xy = np.array([objects[i] for i in o_ids], float).reshape(-1, 2)
        h_xy = np.array([hypotheses[j] for j in h_ids], float).reshape(-1, 2)
        d = np.hypot(o_xy[:, None, 0] - h_xy[None, :, 0], o_xy[:, None, 1] - h_xy[None, :, 1])
        matched = {}
        # correspondences of the previous frame that still hold
        for oi, o in enumerate(o_ids):
            h = self._previous.get(o)
            if h in hypotheses and d[oi, h_ids.index(h)] < self.gate and h not in matched.values():
                matched[o] = h
        free_o = [oi for oi, o in enumerate(o_ids) if o not in matched]
        free_h = [hj for hj, h in enumerate(h_ids) if h not in matched.values()]
        if free_o and free_h:
            sub = d[np.ix_(free_o, free_h)]
            rows, cols = linear_sum_assignment(np.where(sub < self.gate, sub, 1e9))
            for r, c in zip(rows, cols, strict=True):
                if sub[r, c] < self.gate:
                    matched[o_ids[free_o[r]]] = h_ids[free_h[c]]
        counted = {o for o in o_ids if care is None or care.get(o, True)}
        for o in counted:
            self.objects += 1
            h = matched.get(o)
            if h is None:
                self.misses += 1
                if len(self.miss_log) < LOG_LIMIT:
                    self.miss_log.append((t, o))
                continue
            self.matches += 1
            self.distance_sum += float(d[o_ids.index(o), h_ids.index(h)])
            last = self._last.get(o)
            if last is not None and last != h:
                self.switches += 1
                self.switch_log.append((t, o, last, h))
        unmatched = [h for h in h_ids if h not in matched.values()]
        self.unmatched_anywhere += len(unmatched)
        false = [h for h in unmatched if hyp_care is None or hyp_care.get(h, True)]
        self.false_positives += len(false)
        for h in false[:max(0, LOG_LIMIT - len(self.false_positive_log))]:
            self.false_positive_log.append((t, h, tuple(round(float(v), 3) for v in hypotheses[h])))
        for o, h in matched.items():
            if o in counted:
                self._last[o] = h
        self._previous = dict(matched)
        return matched

    def summary(self):
        n = max(self.objects, 1)
        return {
            "frames": self.frames, "objects": self.objects, "matches": self.matches, "misses": self.misses,
            "false_positives": self.false_positives, "id_switches": self.switches,
            "mota": 1.0 - (self.misses + self.false_positives + self.switches) / n if self.objects else None,
            "motp_m": self.distance_sum / self.matches if self.matches else None,
            "false_positives_per_1000_frames": 1000.0 * self.false_positives / max(self.frames, 1),
            "unmatched_anywhere": self.unmatched_anywhere,
        }
