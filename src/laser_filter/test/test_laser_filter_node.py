"""laser_filter_node against a private master, with the seed's launch file: rules applied
to a real message, and malformed scans answered with a warning, not a crash."""

import math

import pytest

from florence_common.processes import roslaunch, stop_all, wait_for

pytestmark = pytest.mark.ros



def scan(ranges, intensities=(), range_max=5.6):
    from sensor_msgs.msg import LaserScan

    msg = LaserScan(angle_min=-0.5, angle_max=0.5, angle_increment=1.0 / max(len(ranges) - 1, 1),
                    range_min=0.02, range_max=range_max, ranges=list(ranges), intensities=list(intensities))
    msg.header.frame_id = "base_laser_link"
    return msg


def test_filters_the_combined_scan_and_survives_bad_scans(ros_master, rospy_node):
    from sensor_msgs.msg import LaserScan

    proc = roslaunch(ros_master, "laser_filter", "laser_filter.launch")
    out = []
    sub = rospy_node.Subscriber("/filtered_scan", LaserScan, out.append)
    pub = rospy_node.Publisher("/scan_combined", LaserScan, queue_size=10)
    try:
        wait_for(lambda: pub.get_num_connections() and sub.get_num_connections(), 30.0, what="laser_filter up")
        bad = [scan([1.0, 2.0], intensities=[1.0]),  # mismatched intensities: published without them
               scan([1.0], range_max=math.nan),  # unusable limits: dropped
               scan([])]  # empty: published empty
        good = scan([0.1, 1.0, 0.0, -1.0, math.nan, math.inf, 6.0], intensities=range(7))
        for i, msg in enumerate([*bad, good]):  # the stamp marks each scan (rospy rewrites seq)
            msg.header.stamp = rospy_node.Time(i + 1)

        def answered(msgs, stamp):
            """Publish msgs (again) and say whether the scan stamped ``stamp`` came out: a loaded node's
            queue of 5 may drop scans sent in a burst, so each step waits for its own answer."""
            for msg in msgs:
                pub.publish(msg)
            return any(m.header.stamp.secs == stamp for m in out)

        wait_for(lambda: answered(bad[:1], 1), 20.0, interval=0.3, what="the mismatched scan filtered")
        # The scan with unusable limits goes just before the empty one: if it were published, it would be
        # answered first.
        wait_for(lambda: answered(bad[1:], 3), 20.0, interval=0.5, what="the empty scan filtered")
        wait_for(lambda: answered([good], 4), 20.0, interval=0.3, what="the good scan filtered")
        assert proc.running()
        by_id = {}
        for m in out:
            by_id.setdefault(m.header.stamp.secs, m)
        clear = 5.6 - 1e-4
        assert by_id[4].ranges == pytest.approx([clear, 1.0, clear, clear, clear, clear, clear])
        assert by_id[4].header.frame_id == "base_laser_link"
        assert list(by_id[4].intensities) == list(range(7))
        assert list(by_id[1].ranges) == pytest.approx([1.0, 2.0]) and list(by_id[1].intensities) == []
        assert 2 not in by_id
        assert list(by_id[3].ranges) == []
    finally:
        sub.unregister()
        pub.unregister()
        stop_all(proc)
