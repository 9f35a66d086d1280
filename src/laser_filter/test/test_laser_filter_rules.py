"""Seed 3.5 rules of the laser filter, one row per rule, on the ROS-free core and the
message conversion."""

import math

import numpy as np
import pytest
from laser_filter.filter import filter_ranges, limits_problem

pytestmark = pytest.mark.unit

RMIN, RMAX, RADIUS = 0.02, 5.6, 0.18
CLEAR = np.float32(RMAX - 1e-4)


@pytest.mark.parametrize(
    "reading, expected",
    [
        (1.0, 1.0),  # an obstacle: unchanged
        (0.5, 0.5),
        (RADIUS + 0.001, RADIUS + 0.001),  # just outside the robot
        (0.1, CLEAR),  # the robot's own structure
        (RADIUS - 0.001, CLEAR),
        (RMAX, CLEAR),  # >= range_max
        (7.0, CLEAR),
        (RMIN, CLEAR),  # <= range_min
        (0.0, CLEAR),  # Hokuyo error code
        (-1.0, CLEAR),  # negative
        (math.nan, CLEAR),
        (math.inf, CLEAR),
        (-math.inf, CLEAR),
    ],
)
def test_rule(reading, expected):
    out = filter_ranges([reading], RMIN, RMAX, RADIUS)
    assert out.dtype == np.float32
    assert out[0] == pytest.approx(np.float32(expected))


def test_input_is_not_modified_and_length_kept():
    ranges = np.array([0.1, 1.0, math.nan], dtype=np.float32)
    out = filter_ranges(ranges, RMIN, RMAX, RADIUS)
    assert math.isnan(ranges[2]) and len(out) == 3


def test_empty_scan_gives_empty_output():
    assert filter_ranges([], RMIN, RMAX, RADIUS).size == 0


def test_kinect_range_max_of_the_combined_scan_is_used():
    # The combined scan carries the Kinect's 4 m: a 5 m Hokuyo reading is out of range.
    assert filter_ranges([5.0], 0.02, 4.0, RADIUS)[0] == pytest.approx(4.0 - 1e-4)


@pytest.mark.parametrize(
    "rmin, rmax, ok",
    [(0.02, 5.6, True), (0.45, 4.0, True), (0.0, math.inf, False), (math.nan, 4.0, False),
     (1.0, 1.0, False), (0.0, 0.0, False), (2.0, 1.0, False)],
)
def test_unusable_limits_are_named(rmin, rmax, ok):
    assert (limits_problem(rmin, rmax) is None) is ok


def test_message_conversion_keeps_header_and_drops_mismatched_intensities():
    from laser_filter.node import filtered_scan
    from sensor_msgs.msg import LaserScan

    msg = LaserScan(range_min=RMIN, range_max=RMAX, angle_min=-1.0, angle_max=1.0, angle_increment=1.0,
                    ranges=[0.1, 1.0, math.inf], intensities=[1.0, 2.0])
    msg.header.frame_id = "base_laser_link"
    out, note = filtered_scan(msg, RADIUS)
    assert out.header.frame_id == "base_laser_link"
    assert out.ranges == pytest.approx([CLEAR, 1.0, CLEAR])
    assert list(out.intensities) == [] and "intensities" in note
    msg.intensities = [1.0, 2.0, 3.0]
    out, note = filtered_scan(msg, RADIUS)
    assert list(out.intensities) == [1.0, 2.0, 3.0] and note is None
    msg.range_max = math.nan
    out, note = filtered_scan(msg, RADIUS)
    assert out is None and "finite" in note
