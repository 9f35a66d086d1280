"""Offline evaluation of slam_gmapping: florence_sim's core and the mapper's core in one process, no ROS.

The simulator (the apartment, its people if asked, the Create with its odometry errors, the Hokuyo
mounted upside down with its noise) runs in fixed 10 ms steps; :class:`florence_eval.tour.TourDriver`
drives the mapping tour from ground truth at 20 Hz, as a person at the keyboard would; every scan
(10 Hz) goes to :class:`gmapping.slam.GridSlam` with the odometry pose of the same instant and the
laser's geometry through its real mount. This is what the node sees on a perfectly synchronised
machine, and repeatable: the same seeds give the same run. The mapper's parameters come from the
shipped launch file (``launch_params``), so the evaluation measures the values that ship.

Used by ``bench/slam.py --offline`` and the regression tests.
"""

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import rospkg

from florence_common.maps import map_file
from florence_eval import slam_metrics
from florence_eval.shipped import XACRO, launch_params
from florence_eval.tour import MAPPING_START, MAPPING_TOUR, TourDriver, clearance_of, interpolate_poses

LAUNCH = Path(rospkg.RosPack().get_path("gmapping")) / "launch" / "slam_gmapping.launch"
WORLD = map_file("apartment", "apartment.world.yaml")
PEOPLE = map_file("apartment", "people.yaml")
MAP_YAML = map_file("apartment", "apartment.yaml")


def shipped_params(**args):
    """slam_gmapping's ``<param>`` values of the shipped launch file (its args' defaults, or ``args``)."""
    return launch_params(LAUNCH, node="slam_gmapping", args=args)


@dataclass
class MappingRun:
    """One mapping run. Times [s] of simulated time; poses (x [m], y [m], yaw [rad]) of the base."""

    truth_t: list = field(default_factory=list)  # every scan's time ...
    truth: list = field(default_factory=list)  # ... and the true pose then
    online_t: list = field(default_factory=list)  # each processed scan's time ...
    online: list = field(default_factory=list)  # ... and the best particle's pose right after it (map frame)
    update_cpu_s: list = field(default_factory=list)  # process time of each processed scan [s]
    scan_cpu_s: float = 0.0  # process time of every call, processed or not [s]
    sim_time_s: float = 0.0
    driven_m: float = 0.0
    collisions: int = 0
    waited_s: float = 0.0  # the driver waited for people
    sidesteps: int = 0  # ... and stepped aside for them
    complete: bool = False
    resamplings: int = 0
    failed_matches: int = 0
    slam: object = None  # the GridSlam at the end


class OfflineMapping:
    """florence_sim's core with the mapper fed from it. ``people``: a people file or None (nobody)."""

    def __init__(self, config, people=None, sim_seed=1, slam_seed=1, start=MAPPING_START, base_overrides=None):
        from florence_sim.robot_model import RobotModel
        from florence_sim.sim import SimConfig, Simulator
        from gmapping.laser import LaserGeometry
        from gmapping.slam import GridSlam

        self.sim = Simulator.from_files(WORLD, people, RobotModel.from_xacro(str(XACRO)), SimConfig(seed=sim_seed),
                                        tuple(start), **(base_overrides or {}))
        laser = self.sim.laser
        self.laser = LaserGeometry.from_transform(laser.mount, laser.angle_min, laser.increment, len(laser.angles))
        self.start = tuple(start)
        self.slam = GridSlam(config, self.odom(), np.random.default_rng(slam_seed))

    def truth(self):
        b = self.sim.base
        return np.array([b.x, b.y, b.yaw])

    def odom(self):
        b = self.sim.base
        return np.array([b.ox, b.oy, b.oyaw])

    def people_xy(self):
        """(x, y, vx, vy) [m, m/s] of everybody, as the person at the keyboard sees them."""
        return [(p.x, p.y, p.vx, p.vy) for p in self.sim.people.values()]

    def run(self, steps=MAPPING_TOUR, timeout=1200.0, v_max=0.3, cmd_rate=20.0, progress=None):
        """Drive ``steps`` (a tour of florence_eval.tour's kinds); ``timeout`` [s] of simulated time.
        ``progress(run)`` is called after every processed scan. Returns a MappingRun."""
        sim, slam, run = self.sim, self.slam, MappingRun()
        driver = TourDriver(steps, v_max=v_max, clearance=clearance_of(WORLD, sim.base.cfg.height))
        cmd_every = max(1, round(1.0 / (cmd_rate * sim.cfg.dt)))
        t_end = sim.time + timeout
        while not driver.done and sim.time < t_end:
            if sim.steps % cmd_every == 0:
                v, w = driver.command(self.truth(), self.people_xy(), dt=cmd_every * sim.cfg.dt)
                sim.base.command(v, w, sim.time)
            before = self.truth()
            due = sim.step()
            after = self.truth()
            run.driven_m += math.hypot(after[0] - before[0], after[1] - before[1])
            if "laser" not in due:
                continue
            ranges = sim.scan()
            t0 = time.process_time()
            result = slam.process_scan(self.odom(), self.laser, ranges, sim.laser.range_min, sim.laser.range_max,
                                       sim.time)
            spent = time.process_time() - t0
            run.scan_cpu_s += spent
            run.truth_t.append(sim.time)
            run.truth.append(after)
            if result.processed:
                run.update_cpu_s.append(spent)
                run.online_t.append(sim.time)
                run.online.append(np.array(slam.best_pose()))
                run.failed_matches += result.failed_matches
                if progress is not None:
                    progress(run)
        sim.base.command(0.0, 0.0, sim.time)
        run.sim_time_s = sim.time
        run.collisions = sim.base.collisions
        run.waited_s = driver.waited
        run.sidesteps = driver.sidesteps
        run.complete = driver.done
        run.resamplings = slam.resamplings
        run.slam = slam
        return run


def evaluate(run, start=MAPPING_START, truth_yaml=MAP_YAML):
    """Figures of a MappingRun against ground truth: trajectory errors (the best particle's final trajectory,
    best-fit aligned (ATE) and anchored at the start; the online estimates), the map's scores
    (florence_eval.slam_metrics), with the grids for the pictures. Returns (figures, grids)."""
    from map_server.mapfile import load_map

    slam = run.slam
    stamps, trajectory = slam.best_trajectory()
    truth_at = interpolate_poses(run.truth_t, run.truth, stamps)
    pos, yaw, (theta, t) = slam_metrics.trajectory_errors(trajectory, truth_at)
    pos_anchor, _, _ = slam_metrics.trajectory_errors(trajectory, truth_at, anchor=start)
    online_truth = interpolate_poses(run.truth_t, run.truth, run.online_t)
    pos_online, _, _ = slam_metrics.trajectory_errors(np.asarray(run.online).reshape(-1, 3), online_truth,
                                                      anchor=start)
    data, origin, resolution = slam.build_map()
    truth = load_map(str(truth_yaml))
    seen = slam_metrics.seen_map(truth_at, slam.scans, resolution, slam.cfg.occ_thresh, truth)
    scores, built = slam_metrics.judge_map(data, origin, resolution, (theta, t), truth, seen)
    scores_anchored, _ = slam_metrics.judge_map(data, origin, resolution, (start[2], start[:2]), truth, seen)
    cpu = np.asarray(run.update_cpu_s)
    figures = {
        **scores,
        "anchored_occupied_f1": scores_anchored["occupied_f1"],
        "anchored_free_agreement": scores_anchored["free_agreement"],
        "ate_rms_m": slam_metrics.rms(pos), "ate_max_m": float(pos.max()) if pos.size else math.nan,
        "yaw_rms_deg": math.degrees(slam_metrics.rms(yaw)),
        "anchored_rms_m": slam_metrics.rms(pos_anchor),
        "online_rms_m": slam_metrics.rms(pos_online),
        "alignment": {"theta_deg": math.degrees(theta), "x_m": float(t[0]), "y_m": float(t[1])},
        "updates": slam.updates, "resamplings": run.resamplings, "failed_matches": run.failed_matches,
        "particles": slam.cfg.particles, "sim_time_s": run.sim_time_s, "driven_m": run.driven_m,
        "collisions": run.collisions, "waited_for_people_s": run.waited_s, "sidesteps": run.sidesteps,
        "complete": run.complete,
        "cpu_s_per_sim_s": run.scan_cpu_s / run.sim_time_s if run.sim_time_s else math.nan,
        "update_cpu_p50_ms": float(np.percentile(cpu, 50) * 1e3) if cpu.size else math.nan,
        "update_cpu_p99_ms": float(np.percentile(cpu, 99) * 1e3) if cpu.size else math.nan,
        "update_cpu_max_ms": float(cpu.max() * 1e3) if cpu.size else math.nan,
        "mapper_memory_mib": slam.memory_bytes() / 2**20,
        "map_cells": [int(data.shape[1]), int(data.shape[0])],
    }
    grids = {"built": built, "truth": truth.data, "seen": seen, "truth_origin": truth.origin[:2],
             "resolution": truth.resolution, "trajectory": slam_metrics.apply_se2(theta, t, trajectory[:, :2]),
             "true_trajectory": truth_at[:, :2]}
    return figures, grids


def run_mapping(params, people=None, sim_seed=1, slam_seed=1, steps=MAPPING_TOUR, progress=None, **overrides):
    """The mapping tour with the mapper's ``params`` (ROS names; ``overrides`` on top). Returns the MappingRun."""
    from gmapping.slam import config_from_params

    merged = {**params, **overrides}
    config = config_from_params(merged.get)
    off = OfflineMapping(config, people, sim_seed, slam_seed)
    return off.run(steps, progress=progress)
