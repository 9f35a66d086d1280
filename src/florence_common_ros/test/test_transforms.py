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
