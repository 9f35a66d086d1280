"""Weights and resampling of GMapping's particle filter (openslam_gmapping ``gridslamprocessor``
normalize and ``particlefilter.h`` uniform_resampler), without ROS.

A particle's weight is a log-likelihood summed since its last resampling. Normalising smooths it
with the gain 1 / (ogain N), so that one scan cannot wipe out the set:

    w_i = exp((l_i - max l) / (ogain N)) / sum_j (...),     N_eff = 1 / sum w_i^2,

and the set is resampled, systematically (one random offset, N evenly spaced pointers into the
cumulative weights), only when N_eff falls below resampleThreshold N.
"""

import numpy as np


def normalise(log_weights, ogain):
    """(normalised weights [N], effective sample size N_eff) of log-likelihood weights [N]."""
    lw = np.asarray(log_weights, dtype=float)
    w = np.exp((lw - lw.max()) / (ogain * len(lw)))
    w /= w.sum()
    return w, 1.0 / float(np.sum(w * w))


def systematic(weights, rng, count=None):
    """Indices of the ``count`` (default: as many as weights) particles drawn in proportion to ``weights``
    [N] (need not sum to 1) by systematic resampling: one uniform offset in [0, interval), then a pointer
    every ``interval`` = total / count. Sorted; a particle of weight w is drawn floor or ceil of
    w count / total times."""
    w = np.asarray(weights, dtype=float)
    count = len(w) if count is None else int(count)
    cumulative = np.cumsum(w)
    interval = cumulative[-1] / count
    pointers = interval * (rng.uniform() + np.arange(count))
    return np.minimum(np.searchsorted(cumulative, pointers, side="right"), len(w) - 1)


def entropy(weights):
    """Entropy [nats] of normalised weights: 0 when one particle holds all the weight, ln N when all are equal."""
    w = np.asarray(weights, dtype=float)
    w = w[w > 0]
    return float(-np.sum(w * np.log(w)))
