"""Offline evaluation of amcl: florence_sim's core and the amcl core in one process, no ROS.

The simulator (apartment world, Hokuyo model with its noise, Create odometry with its scale
errors and noise) runs in fixed 10 ms steps; a waypoint follower drives the robot on ground
truth at 20 Hz; every scan (10 Hz) goes to :class:`amcl.localizer.Localizer` with the odometry
pose of the same instant and the beams through the laser's real mount (upside down). This is
what the node sees on a perfectly synchronised machine, without the message latency and dropped
scans of a loaded one, and it is repeatable: the same seed gives the same run.

The amcl parameters come from a launch file (``launch_params``), so the evaluation measures
the values that ship. Used by ``bench/amcl.py --offline`` and the regression tests; imports
florence_sim (the simulator core, ROS-free) only when called.

Errors are reported in the map frame and, for the bias, split along the true heading
(``along``, x forward) and across it (``across``, y left), in metres.
"""

import math
from dataclasses import dataclass, field

import numpy as np
from amcl.localizer import Localizer, config_from_params
from amcl.sensor import beams_in_base

from florence_common import angles
from florence_common.maps import map_file
from florence_common.pose import matrix_to_transform
from florence_eval import shipped
from florence_eval.shipped import TURTLEBOT_CONTROL, XACRO
from florence_eval.tour import APARTMENT_LOOP, APARTMENT_START, convergence_index, follow, path_length, tour

LAUNCH = TURTLEBOT_CONTROL / "config" / "amcl_turtlebot_control.launch"
WORLD = map_file("apartment", "apartment.world.yaml")
MAP_YAML = map_file("apartment", "apartment.yaml")


def launch_params(path=LAUNCH, node="amcl", args=None):
    """amcl's ``<param>``s in its shipped launch file (florence_eval.shipped.launch_params)."""
    return shipped.launch_params(path, node, args)


def make_config(params, **overrides):
    """AmclConfig from launch-file params with ``overrides`` (ROS parameter names) on top."""
    merged = {**params, **overrides}
    return config_from_params(merged.get)


@dataclass
class Run:
    """One offline run. Times [s] of simulated time; poses (x [m], y [m], yaw [rad])."""

    est_t: list = field(default_factory=list)
    est: list = field(default_factory=list)  # the published estimates (after each resampling)
    truth: list = field(default_factory=list)  # true pose at each estimate's time
    travelled: list = field(default_factory=list)  # [m] distance driven at each estimate
    update_ms: list = field(default_factory=list)  # process time of each filter update [ms]
    collisions: int = 0
    complete: bool = False

    def errors(self):
        """(position error [m], |yaw error| [rad], along [m], across [m]) per estimate (along/across the true
        heading)."""
        est, truth = np.asarray(self.est).reshape(-1, 3), np.asarray(self.truth).reshape(-1, 3)
        dx, dy = est[:, 0] - truth[:, 0], est[:, 1] - truth[:, 1]
        c, s = np.cos(truth[:, 2]), np.sin(truth[:, 2])
        return np.hypot(dx, dy), np.abs(angles.diff(est[:, 2], truth[:, 2])), c * dx + s * dy, -s * dx + c * dy

    def tracking_summary(self):
        """RMS errors after convergence (within 0.1 m / 5 deg for 5 estimates, as bench/amcl.py)."""
        pos, yaw, along, across = self.errors()
        start = convergence_index(pos, yaw, 0.1, math.radians(5.0)) or 0
        sel = slice(start, None)
        return {"estimates": len(pos), "skipped": int(start), "position_rms_m": _rms(pos[sel]),
                "position_max_m": float(np.max(pos[sel])) if len(pos[sel]) else math.nan,
                "yaw_rms_deg": math.degrees(_rms(yaw[sel])), "along_mean_m": float(np.mean(along[sel])),
                "across_mean_m": float(np.mean(across[sel])), "along_rms_m": _rms(along[sel]),
                "across_rms_m": _rms(across[sel]), "driven_m": self.travelled[-1] if self.travelled else 0.0,
                "update_p50_ms": float(np.percentile(self.update_ms, 50)) if self.update_ms else math.nan,
                "update_p99_ms": float(np.percentile(self.update_ms, 99)) if self.update_ms else math.nan,
                "collisions": self.collisions, "complete": self.complete}


def _rms(v):
    v = np.asarray(v, float)
    return float(np.sqrt(np.mean(v * v))) if v.size else math.nan


class OfflineSim:
    """florence_sim's core with amcl fed from it. ``base_overrides``: BaseConfig fields (e.g.
    odom_linear_scale_error) to change the simulated robot; ``sim_seed`` the simulator's noise seed."""

    def __init__(self, config, start=APARTMENT_START, sim_seed=1, amcl_seed=1, base_overrides=None):
        from florence_sim.robot_model import RobotModel
        from florence_sim.sim import SimConfig, Simulator
        from map_server.mapfile import load_map

        self.sim = Simulator.from_files(WORLD, None, RobotModel.from_xacro(str(XACRO)), SimConfig(seed=sim_seed),
                                        tuple(start), **(base_overrides or {}))
        translation, quaternion = matrix_to_transform(self.sim.laser.mount)
        self.laser_xy, self.bearings = beams_in_base(translation, quaternion, self.sim.laser.angles)
        grid = load_map(str(MAP_YAML))
        self.loc = Localizer(config, np.random.default_rng(amcl_seed))
        self.loc.set_map(grid.data, grid.resolution, grid.origin[:2])
        self.driven = 0.0  # [m] true distance driven

    def truth(self):
        b = self.sim.base
        return np.array([b.x, b.y, b.yaw])

    def odom(self):
        b = self.sim.base
        return np.array([b.ox, b.oy, b.oyaw])

    def drive(self, waypoints, run, timeout=600.0, v_max=0.3, stop_when=None, cmd_rate=20.0):
        """Follow ``waypoints`` (x, y) [m] on ground truth, recording into ``run``; ``timeout`` [s] of sim time.

        ``stop_when(run)`` is checked after every estimate. Returns the index of the next waypoint.
        """
        import time

        sim = self.sim
        index, t_end = 0, sim.time + timeout
        cmd_every = max(1, round(1.0 / (cmd_rate * sim.cfg.dt)))
        while index < len(waypoints) and sim.time < t_end:
            if sim.steps % cmd_every == 0:
                v, w, reached = follow(self.truth(), waypoints[index], v_max=v_max)
                while reached and index + 1 < len(waypoints):
                    index += 1
                    v, w, reached = follow(self.truth(), waypoints[index], v_max=v_max)
                if reached:
                    index += 1
                    break
                sim.base.command(v, w, sim.time)
            before = self.truth()
            due = sim.step()
            after = self.truth()
            self.driven += math.hypot(after[0] - before[0], after[1] - before[1])
            if "laser" not in due:
                continue
            ranges = sim.scan().astype(float)
            t0 = time.process_time()
            result = self.loc.process_scan(self.odom(), self.laser_xy, self.bearings, ranges,
                                           sim.laser.range_min, sim.laser.range_max)
            if result.updated:
                run.update_ms.append((time.process_time() - t0) * 1000.0)
            if result.updated and (result.resampled or not run.est):
                run.est_t.append(sim.time)
                run.est.append(np.asarray(result.pose, dtype=float))
                run.truth.append(after)
                run.travelled.append(self.driven)
                if stop_when is not None and stop_when(run):
                    break
        sim.base.command(0.0, 0.0, sim.time)
        run.collisions = sim.base.collisions
        run.complete = index >= len(waypoints)
        return index


def run_tracking(params, length=30.0, sim_seed=1, amcl_seed=1, base_overrides=None, **overrides):
    """The tour of bench/amcl.py (APARTMENT_LOOP from APARTMENT_START, ``length`` [m]) from the known start."""
    config = make_config(params, **overrides)
    off = OfflineSim(config, APARTMENT_START, sim_seed, amcl_seed, base_overrides)
    # the node's initial covariance (initial_cov_* defaults, the launch file sets none)
    off.loc.set_pose(np.array(APARTMENT_START), np.diag([0.25, 0.25, (math.pi / 12) ** 2]))
    run = Run()
    off.drive(tour(APARTMENT_START[:2], APARTMENT_LOOP, length), run, timeout=length / 0.3 * 3 + 120)
    return run


def global_starts():
    """Start poses on the tour for global localization: each loop waypoint, heading to the next one."""
    pts = [APARTMENT_START[:2], *APARTMENT_LOOP]
    return [(pts[i][0], pts[i][1], math.atan2(pts[i + 1][1] - pts[i][1], pts[i + 1][0] - pts[i][0]))
            for i in range(len(pts) - 1)]


def run_global(params, start_index, sim_seed=1, amcl_seed=1, max_drive=15.0, base_overrides=None, **overrides):
    """global_localization at ``global_starts()[start_index]``, then on along the loop until converged
    (8 estimates from the first of 5 in a row within 0.2 m / 10 deg, as bench/amcl.py) or ``max_drive`` [m].

    Returns (Run, distance driven when the converged run began [m] or None).
    """
    config = make_config(params, **overrides)
    start = global_starts()[start_index]
    off = OfflineSim(config, start, sim_seed, amcl_seed, base_overrides)
    off.loc.global_localization()
    off.loc.request_nomotion_update()
    run = Run()

    def converged(r):
        pos, yaw, _, _ = r.errors()
        idx = convergence_index(pos, yaw)
        return idx is not None and len(pos) - idx >= 8

    loop = list(APARTMENT_LOOP[start_index:]) + list(APARTMENT_LOOP[:start_index])
    waypoints = tour(start[:2], loop, max_drive)
    # only as far as max_drive along the path
    keep = []
    for wp in waypoints:
        keep.append(wp)
        if path_length(start[:2], keep) >= max_drive:
            break
    off.drive(keep, run, timeout=max_drive / 0.3 * 3 + 60, stop_when=converged)
    pos_err, yaw_err, _, _ = run.errors()
    idx = convergence_index(pos_err, yaw_err)
    ok = idx is not None and len(pos_err) - idx >= 8
    return run, (run.travelled[idx] if ok else None)
