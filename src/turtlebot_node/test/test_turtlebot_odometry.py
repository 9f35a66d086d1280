"""Odometry and gyro formulas (ROS-free), and the emulator's physics they are checked against."""

import math

import pytest
from turtlebot_node.create_emulator import CreateEmulator
from turtlebot_node.odometry import Gyro, Odometry

from turtlebot_node import create_oi
from turtlebot_node import oi_spec as oi

pytestmark = pytest.mark.unit

STILL = {"distance": 0, "angle": 0, "requested_right_velocity": 0, "requested_left_velocity": 0,
         "requested_velocity": 0}


@pytest.mark.parametrize(("raw", "scale", "expected_dps"), [
    (512, 1.0, 0.0),
    (512 - 512 * 10 / 150, 1.0, 10.0),  # analog falls when turning counter-clockwise
    (512 + 512 * 30 / 150, 1.0, -30.0),
    (512 - 512 * 10 / 150, 1.35, 13.5),  # gyro_scale_correction multiplies the rate
])
def test_gyro_rate_formula(raw, scale, expected_dps):
    gyro = Gyro(measurement_range=150.0, scale_correction=scale)
    gyro.update_calibration(512, stationary=True)
    assert math.degrees(gyro.rate(raw)) == pytest.approx(expected_dps)


def test_gyro_zero_only_from_stationary_readings():
    gyro = Gyro()
    assert gyro.rate(500) is None
    gyro.update_calibration(400, stationary=False)
    assert gyro.offset is None
    for raw in (510, 514):
        gyro.update_calibration(raw, stationary=True)
    assert gyro.offset == 512


def frame(**values):
    f = dict(STILL, user_analog_input=512)
    f.update(values)
    return f


def test_encoder_odometry_with_scale_corrections():
    odo = Odometry(gyro=None, linear_scale=1.1, angular_scale=0.5)
    odo.update(frame(distance=100))  # 100 mm straight ahead
    assert (odo.pose.x, odo.pose.y) == pytest.approx((0.11, 0.0))
    odo.update(frame(angle=90))
    assert odo.pose.theta == pytest.approx(math.pi / 4)


def test_gyro_heading_replaces_encoder_angle_once_calibrated():
    odo = Odometry(Gyro(150.0, 1.0), period=0.015)
    odo.update(frame())  # stationary: zero = 512
    raw = 512 - 512 * 60 / 150  # 60 deg/s
    odo.update(frame(angle=5, user_analog_input=raw, requested_right_velocity=100, requested_left_velocity=-100))
    assert odo.pose.theta == pytest.approx(math.radians(60) * 0.015)  # the encoders' 5 deg are not used


def test_a_turn_commanded_with_drive_does_not_move_the_gyro_zero():
    # Regression: Drive (137) leaves the requested wheel velocities (41, 42) at 0 while turning.
    odo = Odometry(Gyro(150.0, 1.0))
    odo.update(frame())
    odo.update(frame(angle=2, requested_velocity=100, user_analog_input=400))
    assert odo.gyro.offset == 512


def test_implausible_increments_are_rejected():
    odo = Odometry(gyro=None)
    assert not odo.update(frame(distance=5000))
    assert odo.rejected == 1 and odo.pose.x == 0.0


def _drive(emulator, odometry, right, left, seconds):
    parser = create_oi.StreamParser([6])
    emulator.feed(create_oi.command_drive_direct(right, left), 0.0)
    t = emulator._next_tick
    for _ in range(int(seconds / oi.STREAM_PERIOD)):
        for values in parser.feed(emulator.poll(t)):
            odometry.update(values)
        t += oi.STREAM_PERIOD


@pytest.mark.parametrize(("gain", "correction", "heading_factor"), [
    (1.0, 1.0, 1.0),
    (1.25, 1.25, 1.0),  # a gyro short by 1/1.25 is recovered by the documented correction
    (1.25, 1.0, 0.8),  # uncorrected, the heading falls short by the gain
])
def test_gyro_scale_correction_against_the_emulator(gain, correction, heading_factor):
    emulator = CreateEmulator(gyro_gain=gain)
    emulator.feed(bytes([128, 132, 148, 1, 6]), 0.0)
    emulator.poll(0.0)
    odometry = Odometry(Gyro(150.0, correction))
    _drive(emulator, odometry, 0, 0, 0.3)  # stand still: gyro zero
    _drive(emulator, odometry, 150, -150, 3.0)  # turn on the spot
    assert emulator.theta == pytest.approx(3.0 * 0.3 / 0.258, rel=0.02)
    assert odometry.pose.theta == pytest.approx(emulator.theta * heading_factor, abs=2e-3)


def test_emulator_reports_add_up_to_the_true_motion():
    emulator = CreateEmulator()
    emulator.feed(bytes([128, 132, 148, 1, 6]), 0.0)
    emulator.poll(0.0)
    odometry = Odometry(gyro=None)
    _drive(emulator, odometry, 210, 170, 4.0)
    assert odometry.pose.x == pytest.approx(emulator.x, abs=2e-3)
    assert odometry.pose.y == pytest.approx(emulator.y, abs=2e-3)
    assert odometry.pose.theta == pytest.approx(emulator.theta, abs=math.radians(1.0))
