"""The session-wide ``publisher`` fixture (one rospy.Publisher per topic per process)."""

import pytest

pytestmark = pytest.mark.ros


@pytest.mark.ros
def test_one_publisher_per_topic_and_type(publisher):
    from std_msgs.msg import Float64, String

    first = publisher("/harness_check", String)
    assert publisher("harness_check", String) is first, "the same topic, resolved, gives the same publisher"
    assert publisher("/harness_other", String) is not first
    with pytest.raises(ValueError, match="already published as std_msgs/String"):
        publisher("/harness_check", Float64)
    with pytest.raises(ValueError, match="latch=False"):
        publisher("/harness_check", String, latch=True)
