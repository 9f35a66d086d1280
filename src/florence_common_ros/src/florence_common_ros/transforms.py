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


def lookup_recent_matrix(buffer, target, source, stamp, tolerance, timeout=0.0):
    """(4x4 pose of ``source`` in ``target``, None, held) or (None, why, None), for a transform that may reach tf a
    moment after the readings it places (a joint published more slowly than a sensor's frames): the latest
    transform when it is at most ``tolerance`` [s] older than ``stamp`` (``held``: how much older, 0 for a static
    chain), else the one at ``stamp`` as ``lookup_matrix`` (waiting up to ``timeout``; ``held`` 0). The caller
    accepts that the source moved for up to ``tolerance``: keep it small against how fast the chain moves."""
    if tolerance > 0:
        try:
            latest = buffer.lookup_transform(target, source, rospy.Time(0))
        except (tf2_ros.TransformException, rospy.ROSException):
            latest = None
        if latest is not None:
            held = 0.0 if latest.header.stamp.is_zero() else (stamp - latest.header.stamp).to_sec()
            if 0.0 <= held <= tolerance:
                return to_matrix(latest), None, held
    m, why = lookup_matrix(buffer, target, source, stamp, timeout)
    return m, why, (None if m is None else 0.0)
