"""The key table, the speeds and the timing of keyboard teleoperation (ROS-free core)."""

import itertools
import math

import pytest
from turtlebot_teleop.keys import (
    MOVE,
    MOVE_BINDINGS,
    QUIT,
    SPEED,
    STOP,
    KeyboardTeleop,
    TeleopConfig,
)

pytestmark = pytest.mark.unit

REPEAT = 1 / 30  # [s] a terminal's key repeat interval


@pytest.mark.parametrize("key, linear, angular", [
    ("u", 0.3, 1.0), ("i", 0.3, 0.0), ("o", 0.3, -1.0),
    ("j", 0.0, 1.0), ("k", 0.0, 0.0), ("l", 0.0, -1.0),
    ("m", -0.3, -1.0), (",", -0.3, 0.0), (".", -0.3, 1.0),
    (" ", 0.0, 0.0), ("?", 0.0, 0.0), ("I", 0.0, 0.0),  # space, and any other key, stops
])
def test_key_table(key, linear, angular):
    t = KeyboardTeleop()
    kind = t.press(key, 0.0)
    assert kind == (STOP if (linear, angular) == (0.0, 0.0) else MOVE)
    assert t.poll(0.0) == (pytest.approx(linear), pytest.approx(angular))


def test_key_layout_matches_the_keyboard():
    """Left column turns left going forward, right column right; the middle row turns on the spot;
    backing up, m goes back to the left and . back to the right (the path curves to that side)."""
    for left, right in (("u", "o"), ("j", "l")):
        assert MOVE_BINDINGS[left][1] > 0 > MOVE_BINDINGS[right][1]
    for key in "uio":
        assert MOVE_BINDINGS[key][0] == 1
    for key in "m,.":
        assert MOVE_BINDINGS[key][0] == -1
    # from heading 0 the sideways velocity a moment t later is v sin(w t): > 0 is to the left
    for key, side in (("m", 1), (".", -1), ("u", 1), ("o", -1)):
        v, w = MOVE_BINDINGS[key]
        assert side * v * math.sin(w * 0.1) > 0, key


@pytest.mark.parametrize("keys, speed, turn", [
    ("q", 0.33, 1.1), ("z", 0.27, 0.9), ("w", 0.33, 1.0), ("x", 0.27, 1.0), ("e", 0.3, 1.1), ("c", 0.3, 0.9),
    ("qz", 0.297, 0.99),
    ("q" * 20, 0.5, 2.0),  # the limits
    ("z" * 100, 0.01, 0.05),  # never zero
])
def test_speed_keys(keys, speed, turn):
    t = KeyboardTeleop()
    for key in keys:
        assert t.press(key, 0.0) == SPEED
    assert (t.speed, t.turn) == (pytest.approx(speed), pytest.approx(turn))
    assert t.status() == f"currently:\tspeed {speed:.2f} m/s\tturn {turn:.2f} rad/s"
    assert t.poll(0.0) is None  # a speed key alone does not move the robot


def drive(t, events, until, step=0.001):
    """Feed ``events`` [(time, key)] and poll every ``step`` [s] to ``until``; the published
    commands [(time, command)]."""
    out, events = [], sorted(events)
    now = 0.0
    while now <= until:
        while events and events[0][0] <= now:
            t.press(events[0][1], now)
            events.pop(0)
        cmd = t.poll(now)
        if cmd is not None:
            out.append((round(now, 3), cmd))
        now = round(now + step, 6)
    return out


def test_held_key_drives_at_a_steady_rate_and_stops_within_key_timeout_of_release():
    """'i' held 2 s: the terminal sends it once, again after its 0.5 s repeat delay, then 30 times a
    second. The robot is commanded at 10 Hz without a gap, and told to stop key_timeout (0.3 s) after
    the last repeat, then 2 more zeros, then silence."""
    t = KeyboardTeleop()
    events = [(0.0, "i")] + [(0.5 + n * REPEAT, "i") for n in range(int(1.5 / REPEAT))]
    last = events[-1][0]
    out = drive(t, events, 4.0)
    moving = [(s, c) for s, c in out if c != (0.0, 0.0)]
    zeros = [(s, c) for s, c in out if c == (0.0, 0.0)]
    assert all(c == (0.3, 0.0) for _, c in moving)
    gaps = [b[0] - a[0] for a, b in itertools.pairwise(moving)]
    assert max(gaps) <= 0.1 + 0.0015 and min(gaps) >= 0.1 - 0.0015  # steady 10 Hz, also over the repeat delay
    assert moving[-1][0] <= last + 0.3
    assert zeros[0][0] == pytest.approx(last + 0.3, abs=0.002)  # released: no key for key_timeout
    assert [s for s, _ in zeros] == pytest.approx([last + 0.3, last + 0.4, last + 0.5], abs=0.002)
    assert out[-1] == zeros[-1]  # then nothing: the multiplexer lets go
    assert t.wake_time() is None


def test_a_tap_nudges_for_the_repeat_delay():
    t = KeyboardTeleop()
    out = drive(t, [(0.0, "i")], 2.0)
    moving = [s for s, c in out if c != (0.0, 0.0)]
    assert moving[0] == 0.0 and moving[-1] <= 0.7
    assert next(s for s, c in out if c == (0.0, 0.0)) == pytest.approx(0.7, abs=0.002)


def test_stop_key_stops_at_once_and_holds_zero():
    t = KeyboardTeleop()
    out = drive(t, [(0.0, "i"), (0.5, "i"), (0.55, "i"), (0.6, " ")], 1.0)
    assert dict(out)[0.6] == (0.0, 0.0)
    assert all(c == (0.0, 0.0) for s, c in out if s >= 0.6)


def test_another_key_takes_over_at_once():
    t = KeyboardTeleop()
    out = drive(t, [(0.0, "i"), (0.5, "i"), (0.53, "j")], 0.6)
    assert dict(out)[0.53] == (0.0, 1.0)


def test_speed_change_while_driving_is_sent_at_once():
    t = KeyboardTeleop()
    events = [(0.0, "i")] + [(0.5 + n * REPEAT, "i") for n in range(10)] + [(0.52, "q")]
    out = dict(drive(t, events, 0.6))
    assert out[0.52] == (pytest.approx(0.33), 0.0)


def test_quit_keys():
    t = KeyboardTeleop()
    assert t.press("\x03", 0.0) == QUIT
    assert t.press("\x04", 0.0) == QUIT


@pytest.mark.parametrize("bad", [{"speed": 0.0}, {"speed": 0.6}, {"turn": math.nan}, {"key_timeout": 0.0},
                                 {"rate": -1.0}, {"repeat_delay": -0.1}, {"stop_messages": 0}])
def test_bad_configuration_is_refused(bad):
    with pytest.raises(ValueError):
        TeleopConfig(**bad).validate()
