"""KindThrottle: one clock per kind of problem (rospy's throttle has one per call site)."""

import pytest

from florence_common_ros.throttle import KindThrottle

pytestmark = pytest.mark.unit


def test_each_kind_has_its_own_clock():
    logged, now = [], [0.0]
    warn = KindThrottle("node: ", period=5.0, log=logged.append, clock=lambda: now[0])
    assert warn("tilt", "tilt 45 clamped")
    assert warn("led", "LED 9 ignored")  # another kind: not silenced by the first
    assert not warn("tilt", "tilt 50 clamped")
    assert logged == ["node: tilt 45 clamped", "node: LED 9 ignored"]
    assert warn.last == {"tilt": "tilt 50 clamped", "led": "LED 9 ignored"} and warn.latest == "tilt 50 clamped"
    now[0] = 5.0
    assert warn("tilt", "tilt 60 clamped")
    assert logged[-1] == "node: tilt 60 clamped"
