"""The gyro calibration offline: turtlebot_calibration's Calibrator on florence_sim's core, in one
process, repeatable per seed (bench/calibration.py and its regression test).

:class:`SimRobot` is the calibration's Robot over a florence_sim Simulator: its clock is the
simulation's, a turn command is a cmd_vel (0, w), the gyro heading is the simulated odometry's
(turtlebot_node's gyro heading), the wheel angle the simulated ~sensor_state increments, and a
scan the Hokuyo's ranges through the laser's mount (upside down) into base_footprint, as the node
gets them through tf. The ROS run (calibration_control.launch sim:=true) uses the Kinect's narrow
fake laser by default; the offline run uses the Hokuyo, which the core renders without a camera.
"""

import math
import time
from dataclasses import dataclass

from florence_sim.sim import SimConfig, Simulator
from turtlebot_calibration.calibration import CalibrationConfig, CalibrationError, Calibrator, Robot
from turtlebot_calibration.wall import scan_points

from florence_common.angles import diff
from florence_common.maps import map_file

START = (1.0, 2.5, math.pi)  # [m, m, rad] calibration_control.launch sim:=true: 0.95 m from the living room's west wall


class SimRobot(Robot):
    def __init__(self, sim):
        self.sim = sim
        self.gyro_heading = 0.0  # [rad] unwrapped simulated gyro heading
        self.last_yaw = sim.base.oyaw
        self.wheel = 0.0  # [rad] summed ~sensor_state angles
        self.steps = 0

    def _step(self):
        due = self.sim.step()
        self.steps += 1
        base = self.sim.base
        self.gyro_heading += diff(base.oyaw, self.last_yaw)
        self.last_yaw = base.oyaw
        self.wheel += base.take_packet_deltas()[1]
        return due

    def now(self):
        return self.sim.time

    def sleep(self, seconds):
        end = self.sim.time + seconds
        while self.sim.time < end - 1e-9:
            self._step()

    def command(self, angular):
        self.sim.base.command(0.0, float(angular), self.sim.time)

    def next_scan(self, timeout):
        end = self.sim.time + timeout
        while self.sim.time < end:
            if "laser" in self._step():
                laser = self.sim.laser
                ranges = self.sim.scan()
                return self.sim.time, scan_points(ranges, laser.angle_min, laser.increment, laser.range_min,
                                                  laser.range_max, laser.mount)
        return None, "no scan"

    def gyro(self):
        return self.gyro_heading

    def odom(self):
        return self.wheel


@dataclass
class Run:
    """One calibration: the injected error, what it printed, how long it took."""

    gyro_scale_error: float  # the simulated gyro's (after any correction)
    seed: int
    gyro_factor: float | None
    odom_factor: float | None
    sim_seconds: float  # [s] simulated time of the calibration
    cpu_seconds: float  # [s] process CPU
    error: str | None = None  # CalibrationError text, if it failed
    turns: int = 0

    @property
    def truth(self):
        """The factor that recovers the true rate: 1 / (1 + error)."""
        return 1.0 / (1.0 + self.gyro_scale_error)

    @property
    def gyro_factor_error(self):
        """Relative error of the printed gyro factor against the truth."""
        return None if self.gyro_factor is None else self.gyro_factor / self.truth - 1.0


def calibrate(gyro_scale_error, seed=1, people=True, start=START, config=None):
    """Run the calibration in the shipped apartment (with its walking people unless ``people`` is
    false); a :class:`Run`."""
    sim = Simulator.from_files(map_file("apartment", "apartment.world.yaml"),
                               map_file("apartment", "people.yaml") if people else None,
                               config=SimConfig(seed=seed), start=start, gyro_scale_error=gyro_scale_error)
    robot = SimRobot(sim)
    for _ in range(10):  # the first readings exist
        robot._step()
    cpu = time.process_time()
    lines = []
    cal = Calibrator(robot, config or CalibrationConfig(), report=lines.append, warn=lines.append)
    t0 = sim.time
    try:
        result = cal.run()
    except CalibrationError as exc:
        return Run(gyro_scale_error, seed, None, None, sim.time - t0, time.process_time() - cpu, error=str(exc))
    return Run(gyro_scale_error, seed, result.gyro_factor, result.odom_factor, sim.time - t0,
               time.process_time() - cpu, turns=len(result.turns))


def corrected_error(gyro_scale_error, factor):
    """The simulated gyro's error once turtlebot_node applies ``factor``: (1 + e) x factor - 1 (what
    calibration_control.launch sim:=true gyro_scale_correction:=factor sets)."""
    return (1.0 + gyro_scale_error) * factor - 1.0
