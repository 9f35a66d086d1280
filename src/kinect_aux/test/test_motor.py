"""kinect_aux's core: commands checked, motor states decoded (no device)."""

import math

import pytest
from kinect_aux.motor import decode, led_command, tilt_command

from openni_camera import fakenect_dump, kinect

pytestmark = pytest.mark.unit


@pytest.mark.parametrize("asked, sent, clamped", [(10.0, 10.0, False), (31.0, 31.0, False), (-31.0, -31.0, False),
                                                  (45.0, 31.0, True), (-90.0, -31.0, True), (1e9, 31.0, True)])
def test_tilt_is_clamped_to_the_motor_range(asked, sent, clamped):
    value, note = tilt_command(asked)
    assert value == sent
    assert (note is not None) == clamped
    if clamped:
        assert "clamped" in note and "31" in note


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_tilt_that_is_no_number_is_ignored(bad):
    value, note = tilt_command(bad)
    assert value is None and "not a number" in note


def test_led_options():
    assert [led_command(k)[0] for k in range(8)] == list(range(8))
    for bad in (8, 255, 65535):
        value, problem = led_command(bad)
        assert value is None and "0..7" in problem and "blink red/yellow" in problem


def test_decode_a_raw_state():
    raw = fakenect_dump.tilt_state_bytes((-5, 819, 143), 16, 0)
    state = decode(raw)
    assert state.tilt == 8.0 and state.status == 0 and state.status_text == "stopped"
    assert state.counts == (-5, 819, 143)
    g = kinect.GRAVITY / 819
    assert state.acceleration == pytest.approx((143 * g, -5 * g, 819 * g))  # camera_link: forward, left, up
    moving = decode(fakenect_dump.tilt_state_bytes((0, 819, 0), -128, 4))
    assert math.isnan(moving.tilt) and moving.status_text == "moving"
    with pytest.raises(Exception):  # noqa: B017 - struct.error: a record of another size
        decode(b"\0" * 8)
