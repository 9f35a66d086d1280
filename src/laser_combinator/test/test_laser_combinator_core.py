"""Seed 3.7 rules of the laser combinator on the ROS-free core: nearest reading per angle,
geometry through transforms (incl. the upside-down laser), validity, cropping."""

import math

import numpy as np
import pytest
from laser_combinator.combine import Grid, Scan, combine, crop_grid, nearest_per_bin

pytestmark = pytest.mark.unit

INC = 2 * math.pi / 1024  # [rad] URG-04LX step
N = 683


def hokuyo(ranges=None):
    r = np.full(N, 3.0, np.float32) if ranges is None else np.asarray(ranges, np.float32)
    return Scan(-(len(r) // 2) * INC, INC, 0.02, 5.6, r)


def kinect(ranges, angle_min=-0.5, inc=None):
    r = np.asarray(ranges, np.float32)
    inc = 1.0 / len(r) if inc is None else inc
    return Scan(angle_min, inc, 0.45, 4.0, r)


ROLL_PI = np.diag([1.0, -1.0, -1.0, 1.0])  # upright frame -> frame rolled by pi about x
I4 = np.eye(4)


def bin_of(angle):
    return round((angle - hokuyo().angle_min) / INC)


def test_nearest_reading_wins_per_angle():
    h = hokuyo()
    h.ranges[bin_of(0.0)] = 0.8  # the laser sees something nearer than the Kinect here
    k = kinect(np.full(N, 1.5), angle_min=h.angle_min, inc=INC)  # same grid, same frame
    grid, out, first = combine(h, k, I4, I4, max_ang=3.0)
    assert first == 0 and grid.size == N
    assert out[bin_of(0.0)] == pytest.approx(0.8)
    assert out[bin_of(0.5)] == pytest.approx(1.5)
    assert out[bin_of(-0.5)] == pytest.approx(1.5)


def test_inverted_laser_sees_the_kinects_left_on_its_negative_side():
    """An obstacle 1 m to the robot's left (+0.3 rad in the upright Kinect frame) appears at
    -0.3 rad in the upside-down laser frame; +0.3 rad there stays the laser's 3 m."""
    k = kinect(np.full(601, np.inf), angle_min=-0.3, inc=0.001)
    k.ranges[600] = 1.0  # the beam at +0.3 rad
    _, out, _ = combine(hokuyo(), k, I4, ROLL_PI, max_ang=3.0)
    assert out[bin_of(-0.3)] == pytest.approx(1.0, abs=1e-6)
    assert out[bin_of(0.3)] == pytest.approx(3.0)
    assert np.count_nonzero(out < 2.9) == 1


def test_translation_between_sensors_is_accounted_for():
    # Kinect 0.2 m behind the laser, both upright: a 1 m return straight ahead of the
    # Kinect is 0.8 m ahead of the laser.
    t = np.eye(4)
    t[0, 3] = -0.2
    k = kinect(np.full(101, np.inf), angle_min=-0.05, inc=0.001)
    k.ranges[50] = 1.0
    _, out, _ = combine(hokuyo(), k, I4, t, max_ang=3.0)
    assert out[bin_of(0.0)] == pytest.approx(0.8, abs=1e-6)


def test_a_wide_kinect_beam_covers_every_bin_under_it():
    # 5 Kinect beams 0.1 rad wide (16.3 Hokuyo bins each) across -0.25..0.25 rad.
    k = kinect([1.0] * 5, angle_min=-0.2, inc=0.1)
    grid, out, _ = combine(hokuyo(), k, I4, I4, max_ang=3.0)
    covered = np.flatnonzero(out < 2.0)
    angles = grid.angle_min + grid.angle_increment * covered
    assert angles.min() == pytest.approx(-0.25, abs=INC) and angles.max() == pytest.approx(0.25, abs=INC)
    assert covered.size == covered.max() - covered.min() + 1  # no gaps


def test_a_beam_on_a_bin_centre_fills_only_that_bin():
    grid = Grid(-1.0, 0.01, 201)
    out = nearest_per_bin(np.array([0.0]), np.array([2.0]), 0.01, grid)
    assert np.flatnonzero(np.isfinite(out)).tolist() == [100]


@pytest.mark.parametrize("bad", [math.nan, math.inf, -1.0, 0.0, 0.3, 4.5])
def test_invalid_kinect_readings_do_not_count(bad):
    k = kinect(np.full(N, bad), angle_min=hokuyo().angle_min, inc=INC)
    _, out, _ = combine(hokuyo(), k, I4, I4, max_ang=3.0)
    assert out == pytest.approx(np.full(N, 3.0))


@pytest.mark.parametrize("bad", [math.nan, math.inf, -1.0, 0.0, 6.0])
def test_invalid_in_both_is_no_return(bad):
    h = hokuyo(np.full(N, bad))
    k = kinect(np.full(N, bad), angle_min=h.angle_min, inc=INC)
    _, out, _ = combine(h, k, I4, I4, max_ang=3.0)
    assert np.all(np.isposinf(out))


def test_hokuyo_reading_beyond_the_kinect_range_is_kept():
    # Valid for the laser (5 m < 5.6 m): laser_filter later treats it against the Kinect's 4 m.
    h = hokuyo(np.full(N, 5.0))
    _, out, _ = combine(h, kinect([np.inf]), I4, I4, max_ang=3.0)
    assert out == pytest.approx(np.full(N, 5.0))


def test_beams_rounded_past_max_ang_by_the_driver_are_kept():
    """Regression: hokuyo_node rounds max_ang 1.570 to 256 steps (1.5708 rad); those edge
    beams were cropped, so the combined scan was 2 beams shorter than the laser's."""
    grid, first = crop_grid(hokuyo(np.full(513, 3.0)), 1.570)
    assert (grid.size, first) == (513, 0)


def test_grid_is_cropped_to_max_ang():
    grid, first = crop_grid(hokuyo(), 1.0)
    assert grid.angle_min == pytest.approx(-1.0, abs=INC)
    assert grid.angle_min + (grid.size - 1) * grid.angle_increment == pytest.approx(1.0, abs=INC)
    assert first == bin_of(grid.angle_min)


def test_empty_scans_give_defined_output():
    empty = Scan(0.0, INC, 0.02, 5.6, np.zeros(0, np.float32))
    grid, out, _ = combine(empty, empty, I4, I4, max_ang=1.57)
    assert grid.size == 0 and out.size == 0
    grid, out, _ = combine(hokuyo(), empty, I4, ROLL_PI, max_ang=3.0)
    assert out == pytest.approx(np.full(N, 3.0))


def laser_msg(ranges, intensities=(), inc=INC):
    from sensor_msgs.msg import LaserScan

    return LaserScan(angle_min=-(len(ranges) // 2) * inc, angle_increment=inc, range_min=0.02, range_max=5.6,
                     ranges=list(ranges), intensities=list(intensities))


def test_message_fields_follow_table_10_and_mismatched_intensities_are_dropped():
    from laser_combinator.node import combined_scan

    h = laser_msg([3.0] * 11, intensities=range(11))
    h.header.frame_id, h.time_increment, h.scan_time = "base_laser_link", 1e-4, 0.1
    k = laser_msg([1.0] * 3, inc=0.001)
    k.range_min, k.range_max = 0.45, 4.0
    out = combined_scan(h, k, I4, I4, "base_laser_round_link", 1.57)
    assert out.header.frame_id == "base_laser_round_link"
    assert (out.range_min, out.range_max, out.scan_time) == (0.02, 4.0, 0.1)
    assert list(out.intensities) == list(range(11)) and len(out.ranges) == 11
    h.intensities = [1.0, 2.0]
    assert list(combined_scan(h, k, I4, I4, "x", 1.57).intensities) == []


@pytest.mark.parametrize("field, value", [("angle_increment", 0.0), ("angle_min", math.nan), ("range_max", math.inf)])
def test_malformed_scan_messages_are_value_errors(field, value):
    from laser_combinator.node import combined_scan

    bad = laser_msg([1.0] * 5)
    setattr(bad, field, value)
    with pytest.raises(ValueError, match=field):
        combined_scan(laser_msg([3.0] * 5), bad, I4, I4, "x", 1.57)
