"""collision_monitor.sources without a ROS master: a scan taken through tf into the memory, and ~forget:
readings taken before it, or stamped just after it, or whose use began before it and ended after it,
are not used (each would put what was around a carried robot back around it)."""

import math

import numpy as np
import pytest

pytestmark = pytest.mark.unit


@pytest.fixture
def sources(monkeypatch):
    """ScanSources with one laser source (not subscribed), a static tf odom -> laser and a settable
    ROS clock: (sources module, ScanSources, clock [list of one float])."""
    import tf2_ros
    from collision_monitor.obstacles import parse_sources
    from geometry_msgs.msg import TransformStamped

    from collision_monitor import sources as module

    clock = [10.0]
    monkeypatch.setattr(module.rospy, "get_time", lambda: clock[0])
    buffer = tf2_ros.Buffer(debug=False)  # no ~tf2_frames service: no master
    tf = TransformStamped()
    tf.header.frame_id, tf.child_frame_id = "odom", "laser"
    tf.transform.rotation.w = 1.0
    buffer.set_transform_static(tf, "test")
    specs = parse_sources([{"name": "laser", "topic": "/scan", "timeout": 0.5, "required": True}])
    return module, module.ScanSources(specs, "odom", buffer, tf_timeout=0.0, subscribe=False), clock


def scan(stamp, wall=0.6):
    """A scan stamped ``stamp`` [s] of a wall ``wall`` m ahead, over -45..45 degrees."""
    import rospy
    from sensor_msgs.msg import LaserScan

    msg = LaserScan()
    msg.header.stamp, msg.header.frame_id = rospy.Time.from_sec(stamp), "laser"
    msg.angle_min, msg.angle_increment = -math.pi / 4, math.pi / 180
    msg.range_min, msg.range_max = 0.02, 5.6
    a = msg.angle_min + msg.angle_increment * np.arange(91)
    msg.ranges = (wall / np.cos(a)).tolist()
    return msg


def held(src):
    points, _ = src.points()
    return len(points)


def test_a_scan_is_taken_through_tf(sources):
    _, src, _ = sources
    src._on_scan(scan(9.9), "laser")
    points, _ = src.points()
    assert len(points) > 50 and np.allclose(points[:, 0], 0.6, atol=0.02)


def test_forget_drops_readings_taken_before_it_and_just_after(sources):
    module, src, _ = sources
    src._on_scan(scan(9.9), "laser")
    assert held(src)
    src.forget()  # at 10.0
    assert held(src) == 0
    src._on_scan(scan(9.95), "laser")
    assert held(src) == 0, "a scan taken before the carry, on its way"
    src._on_scan(scan(10.0 + module.FORGET_SETTLE / 2), "laser")
    assert held(src) == 0, "stamped just after the call: this node's clock may be behind the sensor's"
    src._on_scan(scan(10.0 + module.FORGET_SETTLE + 0.05), "laser")
    assert held(src) > 50, "what the sensor sees after the settle is taken"


def test_a_scan_whose_use_began_before_forget_is_not_kept(sources, monkeypatch):
    """forget() while the scan waits for its transform (the node's other threads: a service call)."""
    module, src, _ = sources
    real = module.lookup_matrix

    def lookup_then_forget(*args, **kwargs):
        src.forget()
        return real(*args, **kwargs)

    monkeypatch.setattr(module, "lookup_matrix", lookup_then_forget)
    src._on_scan(scan(9.99), "laser")
    assert held(src) == 0
