"""Appearance signatures and re-identification (no ROS).

A signature is the normalised colour histogram of a person's torso pixels: a hue x
saturation histogram of the chromatic pixels (``HUE_BINS`` x ``SAT_BINS``) plus
``GREY_BINS`` brightness bins for the achromatic ones (saturation or value too low for a
hue), so a grey shirt and a white one differ and lighting changes in brightness matter
little. Signatures are compared with OpenCV's ``compareHist`` (Bhattacharyya distance:
0 identical, 1 disjoint).

:class:`Gallery` keeps one averaged signature per persistent id for as long as the node
runs: a track that appears is matched against the ids not held by another live track.
"""

import cv2
import numpy as np

HUE_BINS, SAT_BINS, GREY_BINS = 16, 6, 4
MIN_SAT, MIN_VAL = 50, 40  # below either, a pixel's hue is noise: it counts as grey
SIZE = HUE_BINS * SAT_BINS + GREY_BINS


def signature(rgb_pixels):
    """Signature (float32 [SIZE], sum 1) of RGB pixels [N, 3] uint8; None for no pixels."""
    px = np.asarray(rgb_pixels, dtype=np.uint8).reshape(-1, 1, 3)
    if len(px) == 0:
        return None
    hsv = cv2.cvtColor(px, cv2.COLOR_RGB2HSV).reshape(-1, 3).astype(np.int32)
    h, s, v = hsv[:, 0], hsv[:, 1], hsv[:, 2]
    chromatic = (s >= MIN_SAT) & (v >= MIN_VAL)
    hb = np.minimum(h * HUE_BINS // 180, HUE_BINS - 1)
    sb = np.minimum((s - MIN_SAT) * SAT_BINS // (256 - MIN_SAT), SAT_BINS - 1)
    gb = np.minimum(v * GREY_BINS // 256, GREY_BINS - 1)
    index = np.where(chromatic, hb * SAT_BINS + np.maximum(sb, 0), HUE_BINS * SAT_BINS + gb)
    hist = np.bincount(index, minlength=SIZE).astype(np.float32)
    return hist / hist.sum()


def distance(a, b):
    """Bhattacharyya distance (cv2.compareHist) between two signatures, in [0, 1]."""
    return float(cv2.compareHist(np.asarray(a, np.float32), np.asarray(b, np.float32), cv2.HISTCMP_BHATTACHARYYA))


def blend(mean, new, weight):
    """Running mean of signatures: ``mean`` moved toward ``new`` by ``weight`` (0..1), renormalised."""
    out = (1.0 - weight) * np.asarray(mean, np.float32) + weight * np.asarray(new, np.float32)
    return out / out.sum()


class Gallery:
    """Persistent ids with their averaged signatures."""

    def __init__(self, threshold=0.4, first_id=1):
        self.threshold = float(threshold)  # largest Bhattacharyya distance of a re-identification
        self.signatures = {}  # persistent id -> signature
        self.counts = {}  # persistent id -> signatures averaged into it
        self._next = int(first_id)

    def __len__(self):
        return len(self.signatures)

    def identify(self, sig, exclude=()):
        """(persistent id, distance) of the closest stored signature within the threshold among the
        ids not in ``exclude``; (None, best distance or inf) when none is close enough."""
        best, best_d = None, float("inf")
        for pid, stored in self.signatures.items():
            if pid in exclude or stored is None:
                continue
            d = distance(sig, stored)
            if d < best_d:
                best, best_d = pid, d
        return (best, best_d) if best_d <= self.threshold else (None, best_d)

    def enroll(self, sig=None):
        """A new persistent id for ``sig`` (None: a person not seen in colour yet)."""
        pid = self._next
        self._next += 1
        self.signatures[pid] = None if sig is None else np.asarray(sig, np.float32)
        self.counts[pid] = 0 if sig is None else 1
        return pid

    def forget(self, pid):
        """Drop an id (a provisional one that turned out to be a known person)."""
        self.signatures.pop(pid, None)
        self.counts.pop(pid, None)

    def update(self, pid, sig, min_weight=0.05):
        """Average ``sig`` into the id's signature: the plain mean of the first 1/min_weight
        signatures, then a running mean that weighs each new one by ``min_weight``. An id enrolled
        without a signature takes the first one it gets."""
        if self.signatures.get(pid) is None:
            self.signatures[pid], self.counts[pid] = np.asarray(sig, np.float32), 1
            return
        n = self.counts[pid] + 1
        self.counts[pid] = n
        self.signatures[pid] = blend(self.signatures[pid], sig, max(1.0 / n, min_weight))
