"""Which tracked users to drop (seed 4.2, Table 15; no ROS).

OpenNI kept a lost user for a few seconds at a distance below the Kinect's range; the seed's
filter dropped users nearer than ZERO_RADIUS. Ours keeps that rule (users nearer the camera
than ``zero_radius``) and drops what the tracker's output says plainly: users no sensor has
seen for ``stale_after``.
"""

import numpy as np


def keep_mask(positions, last_seen, camera_xy, now, zero_radius, stale_after):
    """Boolean mask [N] of the users to keep.

    positions [N, 2] and camera_xy (2,) [m] in one frame (camera_xy None: the distance rule is
    not applied); last_seen [N] and now [s]. A user at a NaN position is dropped."""
    positions = np.asarray(positions, dtype=float).reshape(-1, 2)
    last_seen = np.asarray(last_seen, dtype=float).reshape(-1)
    keep = np.isfinite(positions).all(axis=1) & ((now - last_seen) <= stale_after)
    if camera_xy is not None:
        keep &= np.hypot(positions[:, 0] - camera_xy[0], positions[:, 1] - camera_xy[1]) >= zero_radius
    return keep
