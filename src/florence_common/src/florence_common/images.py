"""Depth images (no ROS): the two encodings a Kinect driver publishes, in metres."""

import numpy as np

DEPTH_ENCODINGS = ("32FC1", "16UC1", "mono16")


def depth_metres(depth, encoding):
    """float32 metres, NaN for no return, of a 32FC1 (metres) or 16UC1 / mono16 (millimetres)
    depth array: 0, negative, NaN and infinite readings are no return. ValueError for another
    encoding."""
    if encoding == "32FC1":
        z = np.asarray(depth, dtype=np.float32)
    elif encoding in ("16UC1", "mono16"):
        z = np.asarray(depth, dtype=np.float32) * np.float32(0.001)
    else:
        raise ValueError(f"unsupported depth encoding {encoding!r} (need 32FC1 [m] or 16UC1 [mm])")
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(z) & (z > 0), z, np.float32(np.nan)).astype(np.float32)
