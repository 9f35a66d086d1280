"""Seed 3.6 rules of the velocity filter, one table row each, on the ROS-free core."""

import itertools
import math

import pytest
from velocity_filter.limiter import Limits, VelocityFilter, step_towards

pytestmark = pytest.mark.unit

RATE = 50.0
STEP = 1.0 / RATE  # [m/s] max change per period at 1 m/s^2


@pytest.mark.parametrize(
    "current, desired, max_step, expected",
    [
        (0.0, 0.01, STEP, 0.01),  # within one step: reached at once
        (0.0, 0.5, STEP, STEP),  # accelerating: limited
        (0.5, 0.0, STEP, 0.5 - STEP),  # decelerating: limited too
        (0.0, -0.5, STEP, -STEP),  # backwards
        (-0.1, 0.3, STEP, -0.1 + STEP),  # through zero
        (0.2, 0.2, STEP, 0.2),  # steady
    ],
)
def test_step_towards_is_the_seeds_rule(current, desired, max_step, expected):
    assert step_towards(current, desired, max_step) == pytest.approx(expected)


def run(filt, t0, seconds, command=None):
    """Step the filter for ``seconds`` at RATE, sending ``command`` every step; return outputs."""
    out = []
    for i in range(round(seconds * RATE)):
        now = t0 + i / RATE
        if command is not None:
            filt.command(*command, now)
        out.append(filt.step(now))
    return out


def test_ramp_up_takes_v_over_acc():
    filt = VelocityFilter(Limits(publishing_rate=RATE))
    out = run(filt, 0.0, 1.0, command=(0.4, 0.8))
    # 0.4 m/s at 1 m/s^2 needs 0.4 s = 20 steps; 0.8 rad/s needs 40 steps.
    assert out[18][0] < 0.4 and out[19][0] == pytest.approx(0.4)
    assert out[38][1] < 0.8 and out[39][1] == pytest.approx(0.8)
    diffs = [b[0] - a[0] for a, b in itertools.pairwise(out)]
    assert max(diffs) <= STEP + 1e-12


@pytest.mark.parametrize(
    "command, expected",
    [
        ((10.0, 0.0), (0.5, 0.0)),
        ((-10.0, 0.0), (-0.5, 0.0)),
        ((0.0, 50.0), (0.0, 2.0)),
        ((0.0, -50.0), (0.0, -2.0)),
        ((1e300, -1e300), (0.5, -2.0)),
    ],
)
def test_caps_hold_for_any_input(command, expected):
    filt = VelocityFilter(Limits(publishing_rate=RATE, max_linear_acc=100.0, max_angular_acc=100.0))
    out = run(filt, 0.0, 1.0, command=command)
    assert all(abs(lin) <= 0.5 and abs(ang) <= 2.0 for lin, ang in out)
    assert out[-1] == pytest.approx(expected)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_commands_are_rejected_and_the_previous_kept(bad):
    filt = VelocityFilter(Limits(publishing_rate=RATE))
    assert filt.command(0.2, 0.1, 0.0)
    assert not filt.command(bad, 0.0, 0.01)
    assert not filt.command(0.0, bad, 0.02)
    out = run(filt, 0.0, 0.5)
    assert out[-1] == pytest.approx((0.2, 0.1))
    assert all(math.isfinite(v) for pair in out for v in pair)


def test_timeout_ramps_to_zero_within_timeout_plus_v_over_acc():
    lim = Limits(publishing_rate=RATE, command_timeout=1.0)
    filt = VelocityFilter(lim)
    run(filt, 0.0, 1.0, command=(0.5, -1.0))  # last command at t = 0.98
    last_command = 0.98
    assert filt.linear == pytest.approx(0.5)
    out = run(filt, 1.0, 3.0)
    times = [1.0 + i / RATE for i in range(len(out))]
    # Before the timeout the command holds.
    held = [o for t, o in zip(times, out, strict=True) if t < last_command + 1.0 - 1e-9]
    assert all(o == pytest.approx((0.5, -1.0)) for o in held)
    zero_at = next(t for t, o in zip(times, out, strict=True) if o == (0.0, 0.0))
    assert zero_at <= last_command + lim.command_timeout + max(0.5 / 1.0, 1.0 / 1.0) + 1.0 / RATE
    assert zero_at >= last_command + lim.command_timeout + 0.5  # it ramps, it does not jump


def test_nothing_received_means_zero():
    filt = VelocityFilter()
    assert filt.step(123.0) == (0.0, 0.0)


@pytest.mark.parametrize(
    "field, value",
    [("publishing_rate", 0.0), ("max_linear_acc", -1.0), ("command_timeout", math.nan), ("max_angular_vel", "x")],
)
def test_nonsense_limits_are_refused(field, value):
    with pytest.raises(ValueError, match=field):
        VelocityFilter(Limits(**{field: value}))
