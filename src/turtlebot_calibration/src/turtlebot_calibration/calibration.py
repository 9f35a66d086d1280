"""Gyro and odometry scale calibration against a wall (ROS-free): the procedure and its maths.

The robot faces a straight wall. Standing still it measures the gyro's drift; then, for each
speed, it turns a full circle on the spot and compares the heading change the gyro and the
odometry (the Create's wheel angle) report with the one the wall's angle in the scan gives
(``wall.py``). Every heading is read with the robot at rest, so the scan, gyro and odometry
readings need no time alignment. Per turn (angles [rad], t [s])::

    scan_delta = diff(wall_end, wall_start) + 2 pi k   (k: the whole turns the gyro counted)
    gyro_delta = gyro_end - gyro_start - drift * (t_end - t_start)
    odom_delta = odom_end - odom_start

and, as the original turtlebot_calibration (calibrate.py) printed them::

    gyro factor = 1 / mean(gyro_delta / scan_delta)     multiply gyro_scale_correction with it
    odom factor = 1 / mean(odom_delta / scan_delta)     multiply odom_angular_scale_correction with it

Differences from the original: the wall's angle is fitted in the robot's base frame (an inverted
laser works); headings are taken at rest, averaged over several scans, after every turn (the
original read them while the robot still coasted); each turn ends where the scan started, the
turn target corrected by the gyro factor measured so far (the later turns end facing the wall);
no wall, no scan, no gyro or no odometry ends the run with a reason instead of a wait forever.

The procedure talks to the robot through a small interface (:class:`Robot`), so the ROS node, the
offline benchmark (florence_sim's core) and the unit tests (a synthetic robot) run the same code.
"""

import logging
import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from florence_common.angles import TWO_PI, diff
from turtlebot_calibration.wall import WallConfig, fit_wall

log = logging.getLogger(__name__)

GYRO_PARAM = "turtlebot_node/gyro_scale_correction"
ODOM_PARAM = "turtlebot_node/odom_angular_scale_correction"


class CalibrationError(RuntimeError):
    """The calibration cannot go on; the message says why and what to do."""


class NoScanError(CalibrationError):
    """No scan arrived for scan_timeout."""


class NoWallError(CalibrationError):
    """Scans arrive, but none shows a wall in front."""


class Interrupted(RuntimeError):
    """The robot interface was shut down (Ctrl-C, roslaunch stopping)."""


class Robot:
    """What the procedure needs of a robot (the ROS node, florence_sim's core, a test double).

    Times are [s] on the robot's clock (simulated time in simulation), angles [rad]."""

    def now(self):
        """The current time."""
        raise NotImplementedError

    def sleep(self, seconds):
        """Let ``seconds`` pass (the last command stays in force); raise Interrupted on shutdown."""
        raise NotImplementedError

    def command(self, angular):
        """Turn on the spot at ``angular`` [rad/s] (0: stop)."""
        raise NotImplementedError

    def next_scan(self, timeout):
        """(stamp, points [N, 2] in the base frame) of the next scan that arrives within ``timeout``
        [s], or (None, reason) when none does (no scan, no transform for it, ...)."""
        raise NotImplementedError

    def gyro(self):
        """The gyro's heading, unwrapped (continuous over turns); None when there is no gyro."""
        raise NotImplementedError

    def odom(self):
        """The odometry's (wheel) heading, unwrapped, with the current angular correction applied;
        None when there is none."""
        raise NotImplementedError

    def sync(self, t, timeout):
        """Wait until the gyro and odometry readings include every message stamped up to time ``t``
        (a node that lags behind its messages catches up), at most ``timeout`` [s]; None when they
        do, else why not (a sensor gone silent). Readings that are always current return None."""
        return None

    def odom_lost(self):
        """How many odometry messages went missing so far (each carries an angle increment: a lost
        one is a lost angle). A robot that cannot tell says 0."""
        return 0


@dataclass(frozen=True)
class CalibrationConfig:
    """The procedure's settings (the node's parameters; units in the comments)."""

    speeds: tuple = (0.3, 0.7, 1.0, 1.5)  # [rad/s] one full turn at each (the original's speeds)
    drift_time: float = 10.0  # [s] standing still for the gyro's drift (original imu_calibrate_time)
    align_tolerance: float = 0.1  # [rad] a turn starts only this close to facing the wall (original 0.1)
    align_speed: float = 0.3  # [rad/s] fastest turn while aligning (original 0.3)
    align_gain: float = 1.5  # [1/s] turn rate per rad of misalignment while aligning
    align_timeout: float = 30.0  # [s] to face the wall
    min_speed: float = 0.1  # [rad/s] slowest turn rate while aligning or ending a turn
    decel: float = 1.0  # [rad/s^2] ending a turn: the rate falls as sqrt(2 decel remaining)
    control_period: float = 0.05  # [s] between turn commands (20 Hz)
    scan_samples: int = 5  # scans averaged for one heading at rest
    settle_time: float = 0.5  # [s] stopped before a heading is read
    still_tolerance: float = 0.002  # [rad] heading change over settle_time that counts as at rest
    scan_timeout: float = 2.0  # [s] no scan for this long ends the calibration
    wall_timeout: float = 5.0  # [s] the wall may be hidden (a passer-by) this long
    turn_timeout_factor: float = 3.0  # a turn may take this many times its nominal time
    max_scale_error: float = 0.2  # a factor beyond 1 +- this is implausible (wrong gyro range?)
    wall: WallConfig = field(default_factory=WallConfig)

    def validate(self):
        if not self.speeds or not all(math.isfinite(s) and 0 < s <= 4.0 for s in self.speeds):
            raise ValueError(f"speeds must be one or more turn rates within (0, 4] rad/s, got {self.speeds!r}")
        for name in ("drift_time", "align_tolerance", "align_speed", "align_gain", "align_timeout", "min_speed",
                     "decel", "control_period", "settle_time", "still_tolerance", "scan_timeout", "wall_timeout",
                     "turn_timeout_factor", "max_scale_error"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.scan_samples < 1:
            raise ValueError(f"scan_samples must be at least 1, got {self.scan_samples}")
        self.wall.validate()
        return self


@dataclass(frozen=True)
class Heading:
    """Headings read together with the robot at rest."""

    t: float  # [s] mean stamp of the scans
    wall: float  # [rad] robot heading relative to the wall's normal (mean over the scans)
    wall_spread: float  # [rad] standard deviation of the scans' angles
    gyro: float | None  # [rad] unwrapped gyro heading
    odom: float | None  # [rad] unwrapped odometry heading
    distance: float  # [m] to the wall
    odom_lost: int = 0  # odometry messages lost so far


@dataclass(frozen=True)
class Turn:
    """One full turn, from rest to rest."""

    speed: float  # [rad/s] commanded
    start: Heading
    end: Heading
    scan_delta: float  # [rad] heading change seen by the scan
    gyro_delta: float | None  # [rad] by the gyro, drift removed
    odom_delta: float | None  # [rad] by the odometry

    @property
    def gyro_ratio(self):
        return None if self.gyro_delta is None else self.gyro_delta / self.scan_delta

    @property
    def odom_ratio(self):
        return None if self.odom_delta is None else self.odom_delta / self.scan_delta


@dataclass(frozen=True)
class Result:
    drift: float | None  # [rad/s] gyro drift at rest
    turns: tuple  # of Turn
    gyro_factor: float | None  # multiply gyro_scale_correction with this
    odom_factor: float | None  # multiply odom_angular_scale_correction with this

    def spread(self, which):
        """Largest minus smallest of the per-turn factors (1 / ratio) of "gyro" or "odom"."""
        ratios = [getattr(t, f"{which}_ratio") for t in self.turns]
        factors = [1.0 / r for r in ratios if r]
        return max(factors) - min(factors) if len(factors) > 1 else 0.0


class GapCounter:
    """Counts the messages missing from a stream that should arrive at a steady rate (turtlebot_node's
    ~sensor_state, each carrying the angle since the one before): a gap between stamps of more than
    ``factor`` times the median of the recent gaps is (gap / median - 1) lost messages. A stamp that
    goes back (a simulator restarted) starts over."""

    def __init__(self, history=50, min_history=5, factor=1.6):
        self.gaps = deque(maxlen=history)  # [s]
        self.min_history, self.factor = min_history, factor
        self.last = None  # [s]
        self.lost = 0

    def add(self, stamp):
        if self.last is not None and stamp < self.last:
            self.gaps.clear()
        elif self.last is not None and stamp > self.last:
            gap = stamp - self.last
            self.gaps.append(gap)
            period = float(np.median(self.gaps))
            if len(self.gaps) >= self.min_history and gap > self.factor * period:
                self.lost += round(gap / period) - 1
        self.last = stamp


def scan_turn(wall_start, wall_end, expected):
    """Heading change [rad] the wall's angles say, taking the whole turns from ``expected`` (the
    gyro's or the odometry's count): right as long as that count is off by less than half a turn."""
    d = diff(wall_end, wall_start)
    return d + TWO_PI * round((expected - d) / TWO_PI)


def factor(ratios):
    """1 / mean of the per-turn ratios (measured / true), as the original printed it; None if
    there are none."""
    ratios = [r for r in ratios if r is not None]
    return 1.0 / float(np.mean(ratios)) if ratios else None


def turn_rate(remaining, speed, decel, min_speed):
    """Turn rate [rad/s] with ``remaining`` [rad] to go: ``speed``, falling as sqrt(2 decel
    remaining) near the end, never below ``min_speed``; 0 once there."""
    if remaining <= 0:
        return 0.0
    return min(speed, max(min_speed, math.sqrt(2.0 * decel * remaining)))


class Calibrator:
    """Runs the calibration on a :class:`Robot`. ``report(text)`` gets every progress line (the
    node logs them); :meth:`run` returns a :class:`Result` or raises CalibrationError."""

    def __init__(self, robot, config=None, report=log.info, warn=log.warning):
        self.robot = robot
        self.cfg = (config or CalibrationConfig()).validate()
        self.report = report
        self.warn = warn
        self.has_gyro = robot.gyro() is not None
        self.has_odom = robot.odom() is not None
        self.drift = None  # [rad/s]
        self.t0 = robot.now()  # [s] drift is counted from here (wall-clock seconds since 1970 are too large)
        self.estimate = 1.0  # best gyro (or odometry) factor so far: the turns' target is corrected by it

    # --- readings -------------------------------------------------------------------------------
    def _sync(self, lag=0.0):
        """Gyro and odometry current up to ``lag`` [s] ago, or CalibrationError (a silent sensor)."""
        why = self.robot.sync(self.robot.now() - lag, self.cfg.scan_timeout)
        if why is not None:
            self.robot.command(0.0)
            raise CalibrationError(why)

    def _counter(self):
        """The heading that counts a turn: the gyro's (drift removed), else the odometry's."""
        if self.has_gyro:
            return self.robot.gyro() - (self.drift or 0.0) * (self.robot.now() - self.t0)
        return self.robot.odom()

    def wall(self, timeout=None):
        """The wall of the next scan that shows one within ``timeout`` [s] (default wall_timeout);
        CalibrationError when no scan arrives for scan_timeout or no scan shows a wall."""
        cfg = self.cfg
        deadline = self.robot.now() + (cfg.wall_timeout if timeout is None else timeout)
        reason = "no scan"
        while True:
            stamp, points = self.robot.next_scan(cfg.scan_timeout)
            if stamp is None:
                raise NoScanError(f"no scan for {cfg.scan_timeout:.1f} s ({points}): is the laser (or the "
                                       f"Kinect's fake laser) running and publishing on the scan topic?")
            fit, reason = fit_wall(points, cfg.wall)
            if fit is not None:
                return stamp, fit
            if self.robot.now() >= deadline:
                raise NoWallError(f"no wall in front: {reason}. Place the robot 0.6-2 m from a straight, "
                                       f"empty stretch of wall at least 1 m wide, facing it.")

    def heading(self):
        """Scan, gyro and odometry headings with the robot at rest (settled, then averaged over
        scan_samples scans)."""
        cfg = self.cfg
        self.robot.command(0.0)
        self._settle()
        self._sync()
        gyro0, odom0 = self.robot.gyro(), self.robot.odom()
        stamps, angles, distances = [], [], []
        while len(angles) < cfg.scan_samples:
            stamp, wall = self.wall()
            stamps.append(stamp)
            angles.append(wall.angle)
            distances.append(wall.distance)
        self._sync()
        gyro1, odom1 = self.robot.gyro(), self.robot.odom()
        return Heading(t=float(np.mean(stamps)), wall=float(np.mean(angles)), wall_spread=float(np.std(angles)),
                       gyro=None if gyro0 is None or gyro1 is None else (gyro0 + gyro1) / 2.0,
                       odom=None if odom0 is None or odom1 is None else (odom0 + odom1) / 2.0,
                       distance=float(np.mean(distances)), odom_lost=self.robot.odom_lost())

    def _settle(self):
        """Wait, stopped, until the heading changes by less than still_tolerance over settle_time."""
        cfg = self.cfg
        deadline = self.robot.now() + 10.0 * cfg.settle_time
        self._sync()
        before = self._counter()
        while True:
            self.robot.command(0.0)
            self.robot.sleep(cfg.settle_time)
            self._sync()
            after = self._counter()
            if before is None or after is None or abs(after - before) <= cfg.still_tolerance:
                return
            if self.robot.now() >= deadline:
                self.warn(f"the robot does not come to rest (heading moved {math.degrees(after - before):.2f} deg "
                          f"in {cfg.settle_time:.1f} s): reading on regardless")
                return
            before = after

    # --- motions ----------------------------------------------------------------------------------------
    def align(self):
        """Turn until the robot faces the wall within align_tolerance (original: "Aligning base with wall")."""
        cfg = self.cfg
        self.report("Aligning base with wall")
        deadline = self.robot.now() + cfg.align_timeout
        while True:
            _, wall = self.wall()
            if abs(wall.angle) < cfg.align_tolerance / 2.0:  # aim inside the tolerance: the robot coasts
                break
            if self.robot.now() >= deadline:
                raise CalibrationError(f"could not face the wall within {cfg.align_timeout:.0f} s "
                                       f"(still {math.degrees(wall.angle):.1f} deg off)")
            rate = min(cfg.align_speed, max(cfg.min_speed, cfg.align_gain * abs(wall.angle)))
            self.robot.command(-math.copysign(rate, wall.angle))
        self.robot.command(0.0)

    def measure_drift(self):
        """Gyro drift [rad/s] standing still for drift_time (None without a gyro)."""
        cfg = self.cfg
        if not self.has_gyro:
            return None
        self.report("Estimating imu drift")
        self.robot.command(0.0)
        self._sync()
        t0, g0 = self.robot.now(), self.robot.gyro()
        end = t0 + cfg.drift_time
        while (remaining := end - self.robot.now()) > 1e-3:
            self.robot.command(0.0)
            self.robot.sleep(min(0.5, remaining))
        self._sync()
        t1, g1 = self.robot.now(), self.robot.gyro()
        drift = (g1 - g0) / (t1 - t0)
        self.report(f" ... imu drift is {math.degrees(drift):f} degrees per second")
        return drift

    def _rotate(self, angle, speed, what):
        """Turn on the spot by ``angle`` [rad, as the counter counts; > 0 counter-clockwise] at up to
        ``speed`` [rad/s], slowing down near the end; stop and settle. Returns the counter's change."""
        cfg = self.cfg
        sign = 1.0 if angle >= 0 else -1.0
        begin = self._counter()
        allowed = cfg.turn_timeout_factor * (abs(angle) / speed + 2.0)  # [s]
        t_end = self.robot.now() + allowed
        while True:
            self._sync(lag=cfg.scan_timeout)  # the gyro (or odometry) still speaks
            turned = (self._counter() - begin) * sign
            rate = turn_rate(abs(angle) - turned, speed, cfg.decel * self.estimate, cfg.min_speed)
            if rate == 0.0:
                break
            if self.robot.now() > t_end:
                self.robot.command(0.0)
                raise CalibrationError(f"{what} did not complete in {allowed:.0f} s (turned "
                                       f"{math.degrees(turned):.0f} of {math.degrees(abs(angle)):.0f} deg by the "
                                       f"{'gyro' if self.has_gyro else 'odometry'}): is the robot stuck?")
            self.robot.command(sign * rate)
            self.robot.sleep(cfg.control_period)
        self.robot.command(0.0)
        self._settle()
        return self._counter() - begin

    def turn(self, speed, start):
        """One full turn counter-clockwise at ``speed`` [rad/s] from rest at ``start`` (a Heading),
        ending where it started (the target corrected by the factor estimated so far)."""
        target = TWO_PI / self.estimate  # [rad] in the counter's units
        turned = self._rotate(target, speed, f"the turn at {speed:.2f} rad/s")
        self._find_wall(speed, turned - target)
        end = self.heading()
        gyro_delta = odom_delta = None
        if self.has_gyro:
            gyro_delta = end.gyro - start.gyro - self.drift * (end.t - start.t)
        if self.has_odom:
            lost = end.odom_lost - start.odom_lost
            if lost:
                self.warn(f"{lost} odometry message(s) lost during the turn at {speed:.2f} rad/s: its odometry "
                          "is not used")
            else:
                odom_delta = end.odom - start.odom
        expected = gyro_delta if gyro_delta is not None else odom_delta
        if expected is None:
            raise CalibrationError(f"odometry messages were lost during the turn at {speed:.2f} rad/s and there "
                                   "is no gyro: the turn cannot be counted")
        scan_delta = scan_turn(start.wall, end.wall, expected * self.estimate)
        return Turn(speed=speed, start=start, end=end, scan_delta=scan_delta, gyro_delta=gyro_delta,
                    odom_delta=odom_delta)

    def _find_wall(self, speed, overshoot):
        """After a turn, with the wall out of view: turn back by the ``overshoot`` [rad, counter] past
        the target (a base that reacts late); if the wall is still not there (a scale error of tens of
        percent stops the turn far from where it began), turn on counter-clockwise until it is."""
        cfg = self.cfg
        try:
            self.wall(timeout=cfg.settle_time)
            return
        except NoWallError as exc:
            self.report(f"The wall is out of view after the turn at {speed:.2f} rad/s ({exc}): looking for it")
        if abs(overshoot) > cfg.align_tolerance:
            self._rotate(-overshoot, cfg.align_speed, "turning back to the wall")
            try:
                self.wall(timeout=cfg.settle_time)
                return
            except NoWallError:
                pass
        begin = self._counter()
        while True:
            stamp, points = self.robot.next_scan(cfg.scan_timeout)
            if stamp is None:
                raise NoScanError(f"no scan for {cfg.scan_timeout:.1f} s ({points})")
            fit, _ = fit_wall(points, cfg.wall)
            if fit is not None and fit.angle < cfg.align_tolerance:
                break
            if abs(self._counter() - begin) * self.estimate > TWO_PI:
                self.robot.command(0.0)
                raise NoWallError(f"no wall in front after the turn at {speed:.2f} rad/s, nor in the whole turn "
                                  "after it: did something move in front of the wall?")
            self.robot.command(cfg.align_speed)
        self.robot.command(0.0)

    # --- the whole procedure -----------------------------------------------------------------------
    def run(self):
        cfg = self.cfg
        if not self.has_gyro and not self.has_odom:
            raise CalibrationError("neither gyro nor odometry: nothing to calibrate")
        if not self.has_gyro:
            self.warn("no gyro (turtlebot_node/has_gyro is false or imu/data is silent): calibrating the "
                      "odometry only")
        try:
            self.wall()  # fail fast: no scan or no wall before waiting for the drift
            self.align()
            self.drift = self.measure_drift() or 0.0
            start = self.heading()
            turns = []
            for speed in cfg.speeds:
                if abs(start.wall) > cfg.align_tolerance:
                    self.align()
                    start = self.heading()
                turn = self.turn(speed, start)
                turns.append(turn)
                self._report_turn(turn)
                ratios = [t.gyro_ratio if self.has_gyro else t.odom_ratio for t in turns]
                self.estimate = factor(ratios)
                start = turn.end
        finally:
            self.robot.command(0.0)
        result = Result(drift=self.drift if self.has_gyro else None, turns=tuple(turns),
                        gyro_factor=factor(t.gyro_ratio for t in turns),
                        odom_factor=factor(t.odom_ratio for t in turns))
        self._check(result)
        return result

    def _report_turn(self, turn):
        text = (f"Turn at {turn.speed:.2f} rad/s: scan {math.degrees(turn.scan_delta):.2f} deg "
                f"(wall at {turn.end.distance:.2f} m, spread {math.degrees(turn.end.wall_spread):.2f} deg)")
        self.report(text)
        if turn.odom_ratio is not None:
            self.report(f"Odom error: {100.0 * (turn.odom_ratio - 1.0):f} percent")
        if turn.gyro_ratio is not None:
            self.report(f"Imu error: {100.0 * (turn.gyro_ratio - 1.0):f} percent")

    def _check(self, result):
        """Warn about figures that need a look (they are printed all the same)."""
        cfg = self.cfg
        if self.has_odom and result.odom_factor is None:
            self.warn("odometry messages were lost in every turn: no odometry factor; calibrate again")
        for which, value in (("gyro", result.gyro_factor), ("odom", result.odom_factor)):
            if value is None:
                continue
            if abs(value - 1.0) > cfg.max_scale_error:
                self.warn(f"the {which} factor {value:.3f} is far from 1: check gyro_measurement_range against the "
                          f"gyro's data sheet" if which == "gyro" else
                          f"the {which} factor {value:.3f} is far from 1: are the wheels slipping?")
            spread = result.spread(which)
            if spread > 0.02:
                self.warn(f"the {which} factors of the turns differ by {100 * spread:.1f} %: the scale depends on "
                          f"the speed, or something moved in front of the wall; repeat the calibration")


def result_lines(result):
    """The seed's output lines, exactly (user manual 7.2)."""
    lines = []
    if result.gyro_factor is not None:
        lines.append(f"Multiply the '{GYRO_PARAM}' parameter with {result.gyro_factor:f}")
    if result.odom_factor is not None:
        lines.append(f"Multiply the '{ODOM_PARAM}' parameter with {result.odom_factor:f}")
    return lines
