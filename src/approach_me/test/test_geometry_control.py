"""ApproachMe's geometry (approach_me.geometry: p2r in all four quadrants, r2p non-zero, the way
around the person) and its control closed around a kinematic robot (approach_me.control): from the
front, the side, at 45 degrees, from behind the person, backing up, a person who shifts."""

import math

import numpy as np
import pytest
from approach_me.control import ARRIVE_SHARE, DONE, DRIVE, GAINS, TURN, Approacher, Request

from approach_me import geometry
from florence_common.angles import diff

pytestmark = pytest.mark.unit

P = (2.0, 1.0)  # the person
R0 = (0.0, 1.0)  # the robot at goal time: 2 m west of the person, phi0 = pi (person -> robot points west)


@pytest.mark.parametrize("p2r, expected", [
    (0.0, (1.4, 1.0)),                                   # straight between the person and the robot
    # counter-clockwise from west: south-west
    (math.pi / 4, (2.0 - 0.6 * math.cos(math.pi / 4), 1.0 - 0.6 * math.sin(math.pi / 4))),
    (3 * math.pi / 4, (2.0 + 0.6 * math.cos(math.pi / 4), 1.0 - 0.6 * math.sin(math.pi / 4))),  # south-east
    (-3 * math.pi / 4, (2.0 + 0.6 * math.cos(math.pi / 4), 1.0 + 0.6 * math.sin(math.pi / 4))),  # north-east
    (-math.pi / 4, (2.0 - 0.6 * math.cos(math.pi / 4), 1.0 + 0.6 * math.sin(math.pi / 4))),  # north-west
    (math.pi, (2.6, 1.0)),                               # behind the person
])
def test_goal_position_in_every_quadrant_of_p2r(p2r, expected):
    direction = geometry.approach_direction(P, R0, p2r)
    g = geometry.goal_position(P, direction, 0.6)
    assert g == pytest.approx(expected)
    assert math.dist(g, P) == pytest.approx(0.6)
    # p2r is the counter-clockwise angle at the person from P -> R0 to P -> G
    angle = diff(math.atan2(g[1] - P[1], g[0] - P[0]), math.atan2(R0[1] - P[1], R0[0] - P[0]))
    assert diff(angle, p2r) == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("r2p", [0.0, 0.5, -0.5, math.pi / 2])
def test_final_heading_relative_to_the_line_to_the_person(r2p):
    g = (1.4, 1.0)  # west of the person: facing them is heading 0 (east)
    yaw = geometry.final_heading(g, P, r2p)
    assert yaw == pytest.approx(r2p)
    # seen from the robot, the person is at bearing -r2p
    bearing = diff(math.atan2(P[1] - g[1], P[0] - g[0]), yaw)
    assert bearing == pytest.approx(-r2p)


@pytest.mark.parametrize("sweep_to, sign", [((1.4, 1.0), 0), ((2.0, 0.4), 0), ((2.6, 1.0), 1.0), ((2.6, 1.0), -1.0)])
def test_the_way_is_a_spiral_that_keeps_the_person_at_one_bearing(sweep_to, sign):
    path = geometry.approach_path(R0, P, sweep_to, turn_sign=sign)
    assert path[-1] == sweep_to
    pts = np.array([R0, *path])
    r = np.hypot(pts[:, 0] - P[0], pts[:, 1] - P[1])
    assert np.all(np.diff(r) <= 1e-9), "never nearer the person than the goal, never farther than the start"
    heading = np.arctan2(*np.diff(pts, axis=0)[:, ::-1].T)
    to_person = np.arctan2(P[1] - pts[:-1, 1], P[0] - pts[:-1, 0])
    bearing = np.abs(diff(to_person, heading))
    a = math.atan2(sweep_to[1] - P[1], sweep_to[0] - P[0])
    sweep = abs(diff(a, math.pi)) if sign == 0 else math.pi
    expected = geometry.spiral_bearing(2.0, 0.6, sweep)
    assert np.all(np.abs(bearing - expected) < 0.12), (bearing, expected)
    assert expected < math.radians(75), "inside the laser's +-90 degrees, with a margin"
    if sign:  # which way round: counter-clockwise from the west passes by the south
        assert (min(y for _, y in path) < 0.9) == (sign > 0)


def simulate(request, person=P, robot=(0.0, 1.0, 0.0), seconds=40.0, shift=None, gains=None, turning=0.0):
    """The controller at 10 Hz on a robot integrated at 100 Hz with the base's acceleration limits.
    ``shift``: (t, (dx, dy)) the person steps aside at t; ``turning`` [rad/s]: the robot turns at this
    rate at the start, as last commanded. Returns (final robot pose, least distance to the person, the
    controller, time)."""
    g = gains or GAINS.defaults()
    a = Approacher(g, request, person, robot[:2], 10.0)
    robot = list(robot)
    person = list(person)
    v = 0.0
    w = a.w = turning
    cmd = (0.0, 0.0)
    least = math.inf
    dt = 0.01
    for k in range(int(seconds / dt)):
        t = k * dt
        if shift is not None and abs(t - shift[0]) < dt / 2:
            person[0] += shift[1][0]
            person[1] += shift[1][1]
        if k % 10 == 0:
            out = a.step(tuple(robot), tuple(person))
            cmd = (out.v, out.w)
            if out.phase == DONE:
                break
            if out.phase == "drive" and k > 100:  # after the first second's turn toward the way
                seen = abs(diff(math.atan2(person[1] - robot[1], person[0] - robot[0]), robot[2]))
                a.peak_bearing = max(getattr(a, "peak_bearing", 0.0), seen)
        v += max(-dt, min(dt, cmd[0] - v))
        w += max(-dt, min(dt, cmd[1] - w))  # velocity_filter's 1 rad/s^2
        robot[0] += v * math.cos(robot[2]) * dt
        robot[1] += v * math.sin(robot[2]) * dt
        robot[2] += w * dt
        least = min(least, math.dist(robot[:2], person))
    for _ in range(300):  # the base coasts to rest
        v += max(-dt, min(dt, -v))
        w += max(-dt, min(dt, -w))
        robot[0] += v * math.cos(robot[2]) * dt
        robot[1] += v * math.sin(robot[2]) * dt
        robot[2] += w * dt
    return tuple(robot), least, a, t


def check(request, robot, person=P, start=R0):
    """(position error, heading error) of the final ``robot`` pose: the direction is fixed at goal time
    (by P and ``start``), the position follows the person to ``person``."""
    direction = geometry.approach_direction(P, start, request.p2r)
    gx, gy = geometry.goal_position(person, direction, request.distance)
    yaw = geometry.final_heading(robot[:2], person, request.r2p)
    return math.hypot(robot[0] - gx, robot[1] - gy), abs(diff(yaw, robot[2]))


@pytest.mark.parametrize("name, p2r, r2p, start", [
    ("front", 0.0, 0.0, (0.0, 1.0, 0.0)),
    ("side", math.pi / 2, 0.3, (0.0, 1.0, 0.0)),
    ("45 degrees", -math.pi / 4, -0.4, (0.0, 1.0, 0.5)),
    ("behind", math.pi, 0.0, (0.0, 1.0, 0.0)),
])
def test_closed_loop_reaches_the_pose(name, p2r, r2p, start):
    req = Request(0.6, p2r, r2p, 0.3, 1.0)
    robot, least, a, t = simulate(req, robot=start)
    assert a.phase == DONE, f"{name}: not reached in {t:.0f} s"
    pos, head = check(req, robot, start=start[:2])
    assert pos < 0.025 and head < 0.08, f"{name}: {pos:.3f} m, {head:.3f} rad"
    assert least > 0.6 - 0.05, f"{name}: passed {least:.2f} m from the person"
    assert a.peak_bearing < math.radians(85), f"{name}: the person {a.peak_bearing:.2f} rad off the heading"


def test_phase_one_drives_on_inside_the_tolerance_while_it_closes_in():
    """Phase 1 ends within ARRIVE_SHARE of xy_tolerance, or once the goal is abeam or behind: not on
    entering the tolerance, where the robot stopped up to 0.067 m short (bench/enablers.py, 20 of 20 runs
    short along the line from the person). Entering the tolerance still heading on, it drives on; with the
    goal abeam it turns at once, not round to it."""
    req = Request(0.6, 0.0, 0.0, 0.3, 1.0)
    direction = geometry.approach_direction(P, R0, req.p2r)
    gx, gy = geometry.goal_position(P, direction, req.distance)
    toward = math.atan2(gy - R0[1], gx - R0[0])
    a = Approacher(GAINS.defaults(), req, P, R0, 10.0)
    near = (gx - 0.04 * math.cos(toward), gy - 0.04 * math.sin(toward), toward)  # 0.04 m short, heading on
    out = a.step(near, P)
    assert out.phase == DRIVE and out.v > 0.0, "it stopped 0.04 m short"
    abeam = (gx - 0.03 * math.sin(toward), gy + 0.03 * math.cos(toward), toward)  # 0.03 m to the side
    assert Approacher(GAINS.defaults(), req, P, R0, 10.0).step(abeam, P).phase in (TURN, DONE)
    radial = []
    for p2r in (0.0, 0.6, -1.2, 2.5):
        req = Request(0.6, p2r, 0.0, 0.3, 1.0)
        robot, _, a, _ = simulate(req)
        assert a.phase == DONE
        radial.append(math.dist(robot[:2], P) - 0.6)
    assert max(abs(r) for r in radial) < ARRIVE_SHARE * 0.05 + 0.005, f"{np.round(radial, 3)} m from the distance"


def test_backs_up_to_a_goal_just_behind():
    req = Request(1.5, 0.0, 0.0, 0.3, 1.0)  # 1 m from the person, asked for 1.5: half a metre back
    robot, _, a, _ = simulate(req, robot=(1.0, 1.0, 0.0))
    assert a.phase == DONE
    pos, head = check(req, robot, start=(1.0, 1.0))
    assert pos < 0.06 and head < 0.08
    assert abs(diff(robot[2], 0.0)) < 0.1, "it backed up instead of turning round twice"


def test_follows_a_person_who_shifts():
    req = Request(0.6, math.pi / 2, 0.0, 0.3, 1.0)
    robot, least, a, _ = simulate(req, shift=(3.0, (0.2, -0.2)))
    moved = (P[0] + 0.2, P[1] - 0.2)
    pos, head = check(req, robot, person=moved)
    assert a.phase == DONE and pos < 0.06 and head < 0.08
    assert np.isfinite(least)


def test_does_not_end_while_turning_fast():
    """In position, the heading within the tolerance, but still turning at 1 rad/s (from the last
    steering of phase 1): told to stop there, the robot would coast 0.5 rad past (at 1 rad/s^2)."""
    req = Request(0.6, 0.0, 0.0, 0.3, 1.0)
    direction = geometry.approach_direction(P, R0, req.p2r)
    gx, gy = geometry.goal_position(P, direction, req.distance)
    yaw = geometry.final_heading((gx, gy), P, req.r2p)
    a = Approacher(GAINS.defaults(), req, P, R0, 10.0)
    a.w = 1.0
    assert a.step((gx, gy, yaw - 0.03), P).phase != DONE
    robot, _, a, t = simulate(req, robot=(gx, gy, yaw - 0.03), turning=1.0)
    assert a.phase == DONE, f"not reached in {t:.0f} s"
    pos, head = check(req, robot)
    assert pos < 0.06 and head < 0.05, f"{pos:.3f} m, {head:.3f} rad"


def test_ends_at_the_rate_phase_two_turns_at():
    """The settled rate lets phase 2's own approach end: its deceleration law within the tolerance."""
    g = GAINS.defaults()
    a = Approacher(g, Request(0.6, 0.0, 0.0, 0.3, 1.0), P, R0, 10.0, yaw_tolerance=0.05)
    law = min(g.k_angular * 0.05, math.sqrt(2.0 * g.turn_decel * 0.05))
    assert max(law, g.min_turn_rate) <= a.settled_rate()
    assert a.settled_rate() ** 2 / (2.0 * g.max_ang_acc) <= 0.05 / 2 + 1e-12
