"""The Florence laser filter rules (seed 3.5), ROS-free.

Applied in the seed's order to every reading ``r`` of a scan (ranges in metres):

1. ``r < robot_radius``: a return from the robot's own structure (standoffs, cables)
   is not an obstacle. The seed sets it to 0.0, which rule 2 then turns into the
   clearing value; the combined effect is implemented directly.
2. ``r >= range_max`` or ``r <= range_min`` (which includes 0, the Hokuyo's error codes
   and negative values) and NaN / +-inf: out of range, set to ``range_max - 1e-4`` so
   that the costmap ray-traces the beam and clears it.

Everything else passes unchanged. The scan's own range_min/range_max are used (the
combined scan carries the Kinect's range_max, seed Table 10).
"""

import math

import numpy as np

CLEARING_MARGIN = 1e-4  # [m] the seed's "slightly smaller value"


def limits_problem(range_min, range_max):
    """Why a scan's limits make the rules meaningless (None when they are usable)."""
    if not (math.isfinite(range_min) and math.isfinite(range_max)):
        return f"range_min/range_max must be finite, got {range_min}/{range_max}"
    if range_max - CLEARING_MARGIN <= max(range_min, 0.0):
        return f"range_max ({range_max}) must exceed range_min ({range_min}) and 0 by more than {CLEARING_MARGIN} m"
    return None


def filter_ranges(ranges, range_min, range_max, robot_radius):
    """Return a new float32 array with the two rules applied (see module docstring)."""
    r = np.array(ranges, dtype=np.float32, copy=True)
    with np.errstate(invalid="ignore"):
        # Comparisons with NaN are False, so NaN lands in "not inside".
        inside = (r > range_min) & (r < range_max)
        own = r < robot_radius
    r[own | ~inside] = np.float32(range_max - CLEARING_MARGIN)
    return r
