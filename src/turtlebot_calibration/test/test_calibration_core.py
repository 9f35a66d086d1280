"""The calibration's maths and procedure on synthetic data (no ROS): the wall fit, the turn
bookkeeping, and whole calibrations of a synthetic robot with injected gyro and odometry errors."""

import math

import numpy as np
import pytest
from turtlebot_calibration.calibration import (
    CalibrationConfig,
    CalibrationError,
    Calibrator,
    GapCounter,
    Interrupted,
    Robot,
    Turn,
    factor,
    result_lines,
    scan_turn,
    turn_rate,
)
from turtlebot_calibration.wall import WallConfig, fit_wall, scan_points

from florence_common.pose import rpy_to_matrix

pytestmark = pytest.mark.unit

INC = 2 * math.pi / 1024  # [rad] URG-04LX step


def wall_points(angle, distance=1.0, bearing=0.5, noise=0.0, rng=None, inc=INC):
    """Base-frame points of a straight wall ``distance`` [m] ahead of a robot whose heading is
    ``angle`` [rad] off the wall's normal (CCW positive), beams within +-``bearing``."""
    beams = np.arange(-bearing, bearing, inc)
    world = angle + beams  # beam directions relative to the wall's normal
    r = distance / np.cos(world)
    if noise:
        r = r + (rng or np.random.default_rng(0)).normal(0.0, noise, len(r))
    return np.stack([r * np.cos(beams), r * np.sin(beams)], axis=1)


# --- the wall -----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("angle", [0.0, 0.05, -0.05, 0.3, -0.3, 0.6, -0.6])
def test_wall_angle_and_distance(angle):
    wall, why = fit_wall(wall_points(angle, 1.2))
    assert why is None
    assert wall.angle == pytest.approx(angle, abs=1e-9)
    assert wall.distance == pytest.approx(1.2)
    assert wall.rms < 1e-9


def test_wall_angle_grows_as_the_robot_turns_counter_clockwise():
    """Turning CCW by d moves the wall's points clockwise in the base frame; the angle grows by d,
    as gyro and odometry yaw do."""
    pts = wall_points(0.0, 1.0)
    d = 0.2
    c, s = math.cos(-d), math.sin(-d)
    turned = pts @ np.array([[c, -s], [s, c]]).T
    wall, _ = fit_wall(turned)
    assert wall.angle == pytest.approx(d)


def test_wall_fit_with_noise_is_within_a_tenth_of_a_degree():
    rng = np.random.default_rng(3)
    errors = [fit_wall(wall_points(a, 1.0, noise=0.01, rng=rng))[0].angle - a for a in np.linspace(-0.3, 0.3, 30)]
    assert math.degrees(np.sqrt(np.mean(np.square(errors)))) < 0.3


def test_wall_fit_ignores_a_leg_in_front_of_the_wall():
    pts = wall_points(0.1, 1.5)
    bearing = np.arctan2(pts[:, 1], pts[:, 0])
    leg = np.abs(bearing - 0.05) < 0.04  # a shin 0.6 m away hides part of the wall
    pts[leg] = pts[leg] / np.hypot(pts[leg, 0], pts[leg, 1])[:, None] * 0.6
    assert leg.sum() > 10
    wall, why = fit_wall(pts)
    assert why is None
    assert wall.angle == pytest.approx(0.1, abs=1e-6)


@pytest.mark.parametrize("points, reason", [
    (np.zeros((0, 2)), "0 readings within"),
    (np.full((50, 2), np.nan), "0 readings within"),
    (wall_points(0.0, 5.0), "0 readings within"),  # beyond max_range
    (wall_points(0.0, 1.0, bearing=0.02), "readings within"),  # too few
    (np.random.default_rng(1).uniform(0.5, 2.5, (200, 2)) * [1, 0.3], "do not lie on a straight wall"),
])
def test_no_wall_gives_a_reason(points, reason):
    wall, why = fit_wall(points)
    assert wall is None
    assert reason in why


def test_a_wall_along_the_line_of_sight_is_not_in_front():
    y = np.linspace(0.2, 0.5, 60)
    pts = np.stack([np.linspace(0.6, 2.5, 60), y], axis=1)  # a line running away from the robot
    wall, why = fit_wall(pts, WallConfig(max_bearing=0.5))
    assert wall is None
    assert "not a wall in front" in why


def test_scan_points_through_an_inverted_laser():
    """The Hokuyo hangs upside down (rpy pi 0 0): its counter-clockwise beams run clockwise about
    the robot's z; in the base frame the wall's angle is the same as for an upright laser."""
    angle = 0.25
    pts = wall_points(angle, 1.0, bearing=1.0)
    bearings = np.arctan2(pts[:, 1], pts[:, 0])
    ranges = np.hypot(pts[:, 0], pts[:, 1])
    upright = np.eye(4)
    upright[:3, 3] = [0.1, 0.0, 0.2]
    inverted = upright.copy()
    inverted[:3, :3] = rpy_to_matrix((math.pi, 0.0, 0.0))
    # the inverted laser reports the beams in its own frame: bearing b in base is -b for it
    for mount, laser_bearings in ((upright, bearings), (inverted, -bearings)):
        order = np.argsort(laser_bearings)
        r, b = ranges[order], laser_bearings[order]
        r = np.append(r, [np.inf, np.nan, 0.001])  # no echo, junk, below range_min
        got = scan_points(r, b[0], INC, 0.02, 5.6, mount)
        assert len(got) == len(pts)
        wall, why = fit_wall(got - mount[:2, 3])  # the fit is about the base's origin
        assert why is None
        assert wall.angle == pytest.approx(angle, abs=1e-6)


# --- turn bookkeeping ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("start, end, expected, result", [
    (0.0, 0.0, 2 * math.pi, 2 * math.pi),
    (0.05, -0.10, 2 * math.pi, 2 * math.pi - 0.15),  # stopped short
    (0.0, 0.3, 2 * math.pi * 1.08, 2 * math.pi + 0.3),  # overshot
    (0.0, -0.5, 2 * math.pi * 0.85, 2 * math.pi - 0.5),  # a gyro 15 % off still counts one turn
    (0.0, 0.0, 4 * math.pi, 4 * math.pi),
])
def test_scan_turn_takes_whole_turns_from_the_counter(start, end, expected, result):
    assert scan_turn(start, end, expected) == pytest.approx(result)


def test_turn_rate_slows_down_near_the_end():
    assert turn_rate(3.0, 1.5, 1.0, 0.1) == 1.5
    assert turn_rate(0.5, 1.5, 1.0, 0.1) == pytest.approx(1.0)
    assert turn_rate(0.001, 1.5, 1.0, 0.1) == 0.1
    assert turn_rate(0.0, 1.5, 1.0, 0.1) == 0.0
    assert turn_rate(-0.1, 1.5, 1.0, 0.1) == 0.0


def test_gap_counter_finds_lost_messages():
    rng = np.random.default_rng(2)
    stamps = list(np.cumsum(0.1 + rng.uniform(-0.03, 0.03, 100)))  # 10 Hz with 30 % jitter
    counter = GapCounter()
    for t in stamps:
        counter.add(t)
    assert counter.lost == 0
    for t in (stamps[-1] + 0.3, stamps[-1] + 0.4):  # two missing before this one
        counter.add(t)
    assert counter.lost == 2
    for t in (1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6):  # the clock went back (a new simulation): no loss
        counter.add(t)
    assert counter.lost == 2


def test_factor_is_one_over_the_mean_ratio():
    assert factor([1.05, 1.05]) == pytest.approx(1 / 1.05)
    assert factor([None, 0.9]) == pytest.approx(1 / 0.9)
    assert factor([]) is None


# --- the whole procedure on a synthetic robot ---------------------------------------------------------------


class SyntheticRobot(Robot):
    """A robot turning on the spot in front of a wall: true yaw with an acceleration limit, a gyro
    with scale error, bias and random walk, a wheel odometry with its own scale error, a 10 Hz
    laser with range noise. ``hide(t0, t1)`` puts a person in front of the wall between those times."""

    DT = 0.01  # [s]

    def __init__(self, gyro_error=0.0, odom_error=0.0, bias=0.0, gyro_noise=0.002, range_noise=0.01, yaw=0.05,
                 distance=1.0, has_gyro=True, has_odom=True, scans=True, wall=True, seed=0, t0=0.0, lag=0.0):
        self.rng = np.random.default_rng(seed)
        self.t, self.yaw, self.rate, self.cmd = t0, yaw, 0.0, 0.0
        self.g, self.o = 0.0, 0.0
        self.gyro_error, self.odom_error, self.bias, self.gyro_noise = gyro_error, odom_error, bias, gyro_noise
        self.range_noise, self.distance = range_noise, distance
        self.has_gyro, self.has_odom, self.scans, self.has_wall = has_gyro, has_odom, scans, wall
        self.next_scan_t = t0 + 0.1
        self.hidden = []
        self.max_rate = 0.0
        self.stop_after = math.inf  # [s] raise Interrupted after this time
        self.lag = lag  # [s] a command takes effect this late (a starved node, a busy simulator)
        self.dropped = []  # (t0, t1): odometry messages lost between these times
        self.lost = 0
        self.pending = []  # (time it takes effect, rate)

    def hide(self, t0, t1, width=0.25):
        """A person stands 0.6 m in front between times t0 and t1, hiding the wall within +-width [m]."""
        self.hidden.append((t0, t1, width))

    def now(self):
        return self.t

    def _step(self):
        dt = self.DT
        while self.pending and self.pending[0][0] <= self.t:
            self.cmd = self.pending.pop(0)[1]
        self.rate += max(-4 * dt, min(4 * dt, self.cmd - self.rate))
        self.yaw += self.rate * dt
        rate = self.rate * (1 + self.gyro_error) + self.bias
        rate += self.rng.normal(0.0, self.gyro_noise / math.sqrt(dt)) if self.gyro_noise else 0.0
        self.g += rate * dt
        if any(t0 <= self.t < t1 for t0, t1 in self.dropped):
            self.lost += 1  # one message a step: its increment never arrives
        else:
            self.o += self.rate * (1 + self.odom_error) * dt
        self.t += dt
        self.max_rate = max(self.max_rate, abs(self.rate))
        if self.t > self.stop_after:
            raise Interrupted("stopped")

    def sleep(self, seconds):
        end = self.t + seconds
        while self.t < end - 1e-9:
            self._step()

    def command(self, angular):
        if self.lag:
            self.pending.append((self.t + self.lag, angular))
        else:
            self.cmd = angular

    def next_scan(self, timeout):
        if not self.scans:
            self.sleep(timeout)
            return None, "no message on scan"
        while self.t < self.next_scan_t - 1e-9:
            self._step()
        self.next_scan_t += 0.1
        if not self.has_wall:
            return self.t, self.rng.uniform(0.5, 2.0, (100, 2)) * [1, 0.5]
        pts = wall_points(self.yaw, self.distance, bearing=0.5, noise=self.range_noise, rng=self.rng)
        for t0, t1, width in self.hidden:
            if t0 <= self.t <= t1:
                phi = np.linspace(-1.2, 1.2, 30)  # the front of a 0.2 m body 0.6 m ahead
                pts = np.concatenate([pts[np.abs(pts[:, 1]) > width],
                                      np.stack([0.6 - 0.2 * np.cos(phi), 0.2 * np.sin(phi)], axis=1)])
        return self.t, pts

    def gyro(self):
        return self.g if self.has_gyro else None

    def odom(self):
        return self.o if self.has_odom else None

    def odom_lost(self):
        return self.lost


def calibrate(robot, **config):
    lines = []
    cal = Calibrator(robot, CalibrationConfig(**config), report=lines.append, warn=lambda t: lines.append("W " + t))
    return cal.run(), lines


@pytest.mark.parametrize("gyro_error, odom_error, bias", [(0.05, 0.02, 0.0), (-0.08, -0.03, 0.003)])
def test_injected_scale_errors_are_recovered(gyro_error, odom_error, bias):
    robot = SyntheticRobot(gyro_error=gyro_error, odom_error=odom_error, bias=bias, seed=7)
    result, lines = calibrate(robot)
    assert result.gyro_factor == pytest.approx(1 / (1 + gyro_error), rel=0.003)
    assert result.odom_factor == pytest.approx(1 / (1 + odom_error), rel=0.003)
    assert result.drift == pytest.approx(bias, abs=0.0005)
    assert [t.speed for t in result.turns] == [0.3, 0.7, 1.0, 1.5]
    assert robot.max_rate == pytest.approx(1.5, abs=0.01)
    assert all(t.scan_delta == pytest.approx(2 * math.pi, abs=0.6) for t in result.turns)
    assert "Estimating imu drift" in lines
    assert sum(line.startswith("Imu error: ") for line in lines) == 4
    assert sum(line.startswith("Odom error: ") for line in lines) == 4
    assert not [line for line in lines if line.startswith("W ")]

    # The later turns aim with the factor measured so far: they end where they started.
    last = result.turns[-1]
    assert abs(last.end.wall - last.start.wall) < 0.01
    assert abs(result.turns[0].end.wall - result.turns[0].start.wall) > 0.1  # the first one aims by the raw gyro

    # Run again with the corrected values: the factors come out within 1 % of 1.
    corrected = SyntheticRobot(gyro_error=(1 + gyro_error) * result.gyro_factor - 1,
                               odom_error=(1 + odom_error) * result.odom_factor - 1, bias=bias, seed=8)
    again, _ = calibrate(corrected)
    assert again.gyro_factor == pytest.approx(1.0, abs=0.01)
    assert again.odom_factor == pytest.approx(1.0, abs=0.01)


def test_on_wall_clock_time():
    """On the robot the clock reads seconds since 1970: the drift is counted from the start."""
    result, _ = calibrate(SyntheticRobot(gyro_error=0.05, bias=0.004, t0=1.7e9), speeds=(1.0,), drift_time=5.0)
    assert result.gyro_factor == pytest.approx(1 / 1.05, rel=0.003)


def test_a_large_gyro_error_is_measured_and_flagged():
    """A gyro range set wrong (here 40 % too high a reading) still counts one turn per turn."""
    result, lines = calibrate(SyntheticRobot(gyro_error=0.4), speeds=(0.7, 1.0))
    assert result.gyro_factor == pytest.approx(1 / 1.4, rel=0.005)
    assert any("out of view after the turn at 0.70" in line for line in lines)  # the first turn stops 100 deg short
    assert any("gyro_measurement_range" in line for line in lines if line.startswith("W "))


def test_a_base_that_reacts_late_overshoots_and_turns_back():
    """Commands taking effect 1.5 s late (a busy machine running the simulator fast): the turn at
    1.5 rad/s stops far past the wall, out of the fit's view; the robot turns back."""
    robot = SyntheticRobot(gyro_error=0.05, lag=1.5)
    result, lines = calibrate(robot, speeds=(1.5,), drift_time=5.0)
    assert any("out of view after the turn at 1.50 rad/s" in line for line in lines)
    assert result.gyro_factor == pytest.approx(1 / 1.05, rel=0.005)


def test_lost_odometry_messages_leave_their_turn_out():
    """A busy machine drops odometry messages (each an angle increment) in the second turn: that
    turn's odometry is not used, the other three give the factor."""
    robot = SyntheticRobot(gyro_error=0.05, odom_error=0.03)
    robot.dropped.append((42.0, 42.5))  # during the turn at 0.7 rad/s
    result, lines = calibrate(robot)
    assert [t.odom_delta is None for t in result.turns] == [False, True, False, False]
    assert any("lost during the turn at 0.70 rad/s" in line for line in lines)
    assert result.odom_factor == pytest.approx(1 / 1.03, rel=0.003)
    assert result.gyro_factor == pytest.approx(1 / 1.05, rel=0.003)


def test_the_first_turn_starts_square_to_the_wall():
    robot = SyntheticRobot(yaw=0.5)
    result, lines = calibrate(robot, speeds=(1.0,), drift_time=1.0)
    assert "Aligning base with wall" in lines
    assert abs(result.turns[0].start.wall) < 0.1


def test_without_gyro_the_odometry_is_calibrated():
    result, lines = calibrate(SyntheticRobot(has_gyro=False, odom_error=0.04), speeds=(1.0,))
    assert result.gyro_factor is None and result.drift is None
    assert result.odom_factor == pytest.approx(1 / 1.04, rel=0.003)
    assert any("odometry only" in line for line in lines)
    assert result_lines(result) == [
        f"Multiply the 'turtlebot_node/odom_angular_scale_correction' parameter with {result.odom_factor:f}"]


def test_a_passer_by_hiding_the_wall_for_a_moment_is_waited_out():
    robot = SyntheticRobot(gyro_error=0.05)
    robot.hide(0.5, 2.0, width=1.0)  # while the first readings are taken
    robot.hide(3.0, 5.0)  # in front of a part of the wall while the drift is measured
    result, _ = calibrate(robot, speeds=(1.0,), drift_time=2.0)
    assert result.gyro_factor == pytest.approx(1 / 1.05, rel=0.003)


def test_no_scan_ends_with_a_reason():
    robot = SyntheticRobot(scans=False)
    with pytest.raises(CalibrationError, match=r"no scan for 2\.0 s .*no message on scan.*laser"):
        calibrate(robot)
    assert robot.t < 3.0  # it gave up at once, without standing still for the drift first


def test_no_wall_ends_with_a_reason_and_a_hint():
    robot = SyntheticRobot(wall=False)
    with pytest.raises(CalibrationError, match=r"no wall in front: .* Place the robot"):
        calibrate(robot)
    assert robot.t < 6.0
    assert robot.cmd == 0.0


def test_a_wall_hidden_for_good_ends_the_run_stopped():
    robot = SyntheticRobot()
    robot.hide(5.0, 1e9, width=1.0)  # after the drift, for good
    with pytest.raises(CalibrationError, match="no wall in front"):
        calibrate(robot, drift_time=1.0)
    assert robot.cmd == 0.0


def test_interrupted_run_leaves_the_robot_stopped():
    robot = SyntheticRobot()
    robot.stop_after = 14.0  # during the first turn
    with pytest.raises(Interrupted):
        calibrate(robot)
    assert robot.cmd == 0.0


def test_nothing_to_calibrate():
    with pytest.raises(CalibrationError, match="neither gyro nor odometry"):
        calibrate(SyntheticRobot(has_gyro=False, has_odom=False))


def test_output_lines_are_the_seeds():
    turn = Turn(speed=1.0, start=None, end=None, scan_delta=2 * math.pi, gyro_delta=2 * math.pi / 1.171401,
                odom_delta=2 * math.pi / 1.015922)
    from turtlebot_calibration.calibration import Result

    result = Result(drift=0.0, turns=(turn,), gyro_factor=factor([turn.gyro_ratio]),
                    odom_factor=factor([turn.odom_ratio]))
    assert result_lines(result) == [
        "Multiply the 'turtlebot_node/gyro_scale_correction' parameter with 1.171401",
        "Multiply the 'turtlebot_node/odom_angular_scale_correction' parameter with 1.015922",
    ]


@pytest.mark.parametrize("bad", [{"speeds": ()}, {"speeds": (0.5, -1.0)}, {"drift_time": 0.0},
                                 {"scan_samples": 0}, {"wall": WallConfig(max_range=0.1, min_range=0.2)}])
def test_bad_configuration_is_refused(bad):
    with pytest.raises(ValueError):
        CalibrationConfig(**bad).validate()
