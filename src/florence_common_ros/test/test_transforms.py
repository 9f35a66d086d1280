"""lookup_matrix: a transform as a 4x4 matrix, or the reason there is none (never an exception)."""

import pytest

pytestmark = pytest.mark.ros  # tf2_ros.Buffer registers a service with the master


def test_a_known_transform_and_the_reason_for_an_unknown_one(rospy_node):
    rospy = rospy_node
    import tf2_ros

    from florence_common_ros.convert import transform_stamped
    from florence_common_ros.transforms import lookup_matrix

    buffer = tf2_ros.Buffer()
    buffer.set_transform(transform_stamped(rospy.Time(10), "odom", "base_footprint", 1.0, 2.0, 0.5), "test")
    m, why = lookup_matrix(buffer, "odom", "base_footprint", rospy.Time(10))
    assert why is None and m[:2, 3] == pytest.approx((1.0, 2.0))
    m, why = lookup_matrix(buffer, "map", "base_footprint", rospy.Time(10))
    assert m is None and why.startswith("no transform base_footprint -> map")
    m, why = lookup_matrix(buffer, "odom", "base_footprint", rospy.Time(99))  # extrapolation
    assert m is None and "extrapolation" in why.lower()
    m, why = lookup_matrix(buffer, "", "base_footprint", rospy.Time(10))  # an invalid frame
    assert m is None
    m, why = lookup_matrix(buffer, "map", "base_footprint", rospy.Time(10), timeout=0.05)  # waits, then gives up
    assert m is None and "map" in why


def test_the_latest_transform_stands_in_for_one_a_moment_late(rospy_node):
    """lookup_recent_matrix: a mount on tf up to ``tolerance`` behind the reading is taken from the latest
    transform (held: how far behind); further behind, or with tolerance 0, the lookup at the stamp decides."""
    rospy = rospy_node
    import tf2_ros

    from florence_common_ros.convert import transform_stamped
    from florence_common_ros.transforms import lookup_recent_matrix

    buffer = tf2_ros.Buffer()
    buffer.set_transform(transform_stamped(rospy.Time(9), "base_link", "camera", 0.1, 0.0, 0.0), "test")
    buffer.set_transform(transform_stamped(rospy.Time(10), "base_link", "camera", 0.2, 0.0, 0.0), "test")
    m, why, held = lookup_recent_matrix(buffer, "base_link", "camera", rospy.Time(10, 100_000_000), 0.25)
    assert why is None and m[0, 3] == pytest.approx(0.2) and held == pytest.approx(0.1)
    m, why, held = lookup_recent_matrix(buffer, "base_link", "camera", rospy.Time(9, 500_000_000), 0.25)
    assert why is None and m[0, 3] == pytest.approx(0.15) and held == 0.0  # within the history: interpolated
    m, why, held = lookup_recent_matrix(buffer, "base_link", "camera", rospy.Time(10, 400_000_000), 0.25)
    assert m is None and held is None and "extrapolation" in why.lower()
    m, why, held = lookup_recent_matrix(buffer, "base_link", "camera", rospy.Time(10, 100_000_000), 0.0)
    assert m is None and "extrapolation" in why.lower()
    buffer.set_transform_static(transform_stamped(rospy.Time(0), "camera", "optical", 0.0, 0.0, 0.0), "test")
    m, why, held = lookup_recent_matrix(buffer, "camera", "optical", rospy.Time(50), 0.25)
    assert why is None and held == 0.0  # a static chain is never late
    m, why, held = lookup_recent_matrix(buffer, "map", "camera", rospy.Time(10), 0.25)
    assert m is None and "map" in why
