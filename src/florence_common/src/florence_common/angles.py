"""Planar angles [rad]: one convention for the whole workspace.

- :func:`wrap` maps any angle into [-pi, pi).
- :func:`diff` is ``a - b`` wrapped: the signed rotation that takes ``b`` to ``a``
  (``diff(goal, yaw) > 0`` means "turn counter-clockwise", REP 103).

Both take a float (and return a float) or anything array-like (and return an ndarray),
so the same call serves one pose and a particle set. :func:`wrap_scalar` is the
float-only body, plain arithmetic that numba compiles (``numba.njit(wrap_scalar)``) for
the kernels that need it.
"""

import math

import numpy as np

PI = math.pi
TWO_PI = 2.0 * math.pi


def wrap_scalar(a):
    """``a`` [rad] wrapped to [-pi, pi) (float arithmetic only; numba-compilable)."""
    r = (a + PI) % TWO_PI - PI
    # (tiny negative) % 2pi rounds to 2pi: the result would be +pi, outside the interval
    return r if r < PI else -PI


def wrap(a):
    """Angle(s) ``a`` [rad] wrapped to [-pi, pi); a float for a number, an ndarray otherwise."""
    if isinstance(a, (float, int)):  # np.float64 is a float
        return wrap_scalar(float(a))
    r = (np.asarray(a, dtype=float) + PI) % TWO_PI - PI
    return np.where(r < PI, r, -PI)


def diff(a, b):
    """``a - b`` [rad] wrapped to [-pi, pi): the signed rotation from ``b`` to ``a``."""
    if isinstance(a, (float, int)) and isinstance(b, (float, int)):
        return wrap_scalar(float(a) - float(b))
    return wrap(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))


def circular_mean(angles, weights=None):
    """Weighted mean direction [rad] of ``angles``, in [-pi, pi) (atan2 of the summed sines and cosines)."""
    angles = np.asarray(angles, dtype=float)
    w = np.ones_like(angles) if weights is None else np.asarray(weights, dtype=float)
    return wrap_scalar(math.atan2(float(np.dot(w, np.sin(angles))), float(np.dot(w, np.cos(angles)))))
