"""tf lookups that never raise in a callback (rospy)."""

import rospy
import tf2_ros

from florence_common_ros.convert import to_matrix


def lookup_matrix(buffer, target, source, stamp, timeout=0.0):
    """(4x4 pose of ``source`` in ``target`` at ``stamp``, None) or (None, why): every tf2 error
    (no such frame, no path, extrapolation, a bad argument, a timeout) and simulated time jumping
    back while waiting come back as the reason text, so that a callback skips its reading with a
    warning instead of raising. ``timeout`` [s] of ROS time to wait for the transform."""
    try:
        return to_matrix(buffer.lookup_transform(target, source, stamp, rospy.Duration(timeout))), None
    except (tf2_ros.TransformException, rospy.ROSException) as exc:
        return None, f"no transform {source} -> {target}: {exc}"
