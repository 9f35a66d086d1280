"""Benchmark of move_base's planners on the costmaps the product builds: navfn's plan
(move_base.navfn.NavfnPlanner.make_plan) and one cycle of the local planner.

    source devel/setup.bash && /usr/bin/python3 bench/nav_plan.py [--repeat 5] [--big-plans 6]

Prints the figures and writes bench/results/nav_plan.json. No ROS master needed: the parameters
are those move_base_turtlebot_control.launch gives move_base (read by roslaunch's loader,
florence_eval.nav_config), and the costmaps are move_base's own layers
(move_base.costmap_config.CostmapConfig: static layer, obstacle layer, inflation layer).

Cases:
- apartment: the global costmap over maps/apartment/apartment.yaml (the map on the robot), plans
  between every ordered pair of room hotspots of maps/apartment/rooms.yaml. Target p50 <= 30 ms.
  ``costmap_update_ms``: one update of that costmap (static map and its inflation).
- synthetic: the same costmap configuration over a 2000 x 2000 cell map (100 m x 100 m at 0.05 m)
  with random rectangular obstacles, plans between far-apart free points. Target p50 <= 1 s.
- local_planner: one control cycle (LocalPlanner.compute_velocity) with the launch file's
  TrajectoryPlannerROS values (6 x 20 samples and the rotations, sim_time 1.5 s) on the local
  costmap (4 m x 4 m rolling window at 0.05 m) with a corridor's walls marked by an observation,
  along a winding plan. Target p99 <= 15 ms (the seed's controller_frequency is 5 Hz).
numba's compile time is reported separately (``compile_s``: a fresh, uncached compile of the
planner's jitted functions; ``first_call_s``: the first plan, which loads numba's on-disk cache
when there is one); the timings exclude it (one warm-up call first).
"""

import argparse
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import yaml
from florence_eval.metrics import Stopwatch
from florence_eval.nav_config import move_base_params
from map_server.mapfile import load_map
from move_base.costmap_2d import FREE_SPACE
from move_base.costmap_config import CostmapConfig
from move_base.local_planner import LocalPlanner
from move_base.trajectory_planner import PlannerParams

from florence_common.maps import map_file
from move_base import navfn

RESULTS = Path(__file__).resolve().parent / "results" / "nav_plan.json"
TARGETS_MS = {"apartment": 30.0, "synthetic_2000": 1000.0}  # p50
LOCAL_TARGET_MS = 15.0  # p99


def global_costmap(params, data, resolution, origin=(0.0, 0.0)):
    """move_base's global costmap (the launch file's ``global_costmap`` values) over a map (row-major
    int8 OccupancyGrid values), updated once: (costmap, update time [ms])."""
    layered = CostmapConfig.read(params["global_costmap"].get).layered()
    height, width = data.shape
    layered.set_static_map(data.ravel(), width, height, resolution, origin[0], origin[1])
    t0 = time.perf_counter()
    layered.update(origin[0], origin[1])
    return layered.costmap, (time.perf_counter() - t0) * 1e3


def synthetic_map(size, seed):
    """OccupancyGrid values (size x size, int8) with random rectangles (one per 100 x 100 cells on average)."""
    rng = np.random.default_rng(seed)
    data = np.zeros((size, size), dtype=np.int8)
    for _ in range(size * size // 10000):
        x, y = rng.integers(0, size - 10, 2)
        w, h = rng.integers(3, 60, 2)
        data[y:y + h, x:x + w] = 100
    return data


def free_points(cm, rng, count, margin):
    """``count`` random world points (x, y) [m] on free cells, ``margin`` cells from the edge."""
    ys, xs = np.nonzero(cm.costs[margin:-margin, margin:-margin] == FREE_SPACE)
    pick = rng.choice(len(xs), count, replace=False)
    wx, wy = cm.map_to_world(xs[pick] + margin, ys[pick] + margin)
    return list(zip(wx, wy, strict=True))


def compile_time():
    """Seconds for a fresh (uncached) numba compile of navfn's jitted functions."""
    import numba

    t0 = time.perf_counter()
    for fn in (navfn._cell_update, navfn._cell_gradient, navfn._propagate, navfn._descend):
        fresh = numba.njit(fn.py_func)
        for sig in fn.signatures:
            fresh.compile(sig)
    return time.perf_counter() - t0


def timings(watch):
    """The stopwatch's percentiles (wall and CPU) and the longest wall time [ms]."""
    return {**watch.summary(), "max_ms": float(max(watch.wall_ms))}


def run_case(planner, cm, pairs, repeat):
    watch, fails, lengths = Stopwatch(), [], []
    for _ in range(repeat):
        for start, goal in pairs:
            with watch:
                res = planner.make_plan(cm, start, goal)
            if not res.ok:
                fails.append(f"{start[:2]} -> {goal[:2]}: {res.reason}")
            else:
                lengths.append(float(np.sum(np.hypot(*np.diff(res.poses[:, :2], axis=0).T))))
    return {**timings(watch), "cells": int(cm.costs.size), "failures": sorted(set(fails)),
            "mean_path_length_m": float(np.mean(lengths)) if lengths else None}


def local_planner_case(params, cycles=100):
    """Cycle times of the local planner in a corridor 1.6 m wide (walls marked through the obstacle
    layer) of the local costmap, the robot weaving along a winding plan."""
    cfg = CostmapConfig.read(params["local_costmap"].get)
    layered = cfg.layered()
    wall_x = np.arange(-2.0, 2.0, 0.02)
    walls = np.concatenate([np.column_stack([wall_x, np.full_like(wall_x, y), np.full_like(wall_x, 0.1)])
                            for y in (-0.8, 0.8)])
    source = cfg.sources[0].name
    layered.obstacles.add_observation(source, np.array([0.0, 0.0, 0.1]), walls, stamp=0.0, now=0.0)
    layered.update(0.0, 0.0)
    cm = layered.costmap
    tp = dict(params["TrajectoryPlannerROS"])
    tp.setdefault("controller_frequency", params.get("controller_frequency", 20.0))
    lp = LocalPlanner(PlannerParams.from_dict(tp), cfg.footprint, layered.inscribed_radius,
                      layered.circumscribed_radius)
    t = np.linspace(0.0, 1.0, 120)
    plan = np.column_stack([-1.8 + 3.6 * t, 0.2 * np.sin(3.0 * t), np.zeros_like(t)])
    lp.set_plan(plan)
    lp.compute_velocity(cm, (0.0, 0.0, 0.2), (0.3, 0.0, 0.1), plan)  # warm-up: numba compile or cache load
    watch = Stopwatch()
    for i in range(cycles):
        pose = (-1.0 + 0.02 * i, 0.2 * math.sin(0.1 * i), 0.2 * math.cos(0.1 * i))
        with watch:
            lp.compute_velocity(cm, pose, (0.3, 0.0, 0.1), plan)
    p = lp.params
    return {**timings(watch), "samples": p.vx_samples * p.vtheta_samples + p.vtheta_samples + 1,
            "costmap": f"{cm.size_x} x {cm.size_y} cells at {cm.resolution} m"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=5, help="passes over the apartment's room pairs")
    ap.add_argument("--big-size", type=int, default=2000, help="synthetic map side [cells]")
    ap.add_argument("--big-plans", type=int, default=6, help="plans on the synthetic map")
    ap.add_argument("--cycles", type=int, default=100, help="local planner cycles timed")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    params = move_base_params()
    planner = navfn.NavfnPlanner(**params.get("NavfnROS", {}))
    grid = load_map(map_file("apartment", "apartment.yaml"))
    apartment, update_ms = global_costmap(params, grid.data, grid.resolution, grid.origin[:2])
    rooms = yaml.safe_load(map_file("apartment", "rooms.yaml").read_text())["rooms"]
    spots = {name: (r["hotspot"]["x"], r["hotspot"]["y"], r["hotspot"]["phi"]) for name, r in sorted(rooms.items())}
    pairs = [(spots[a], spots[b]) for a in spots for b in spots if a != b]

    t0 = time.perf_counter()
    planner.make_plan(apartment, *pairs[0])  # warm-up: numba compile or cache load
    first_call = time.perf_counter() - t0
    compile_s = compile_time()

    results = {"compile_s": compile_s, "first_call_s": first_call, "targets_ms_p50": TARGETS_MS}
    results["apartment"] = run_case(planner, apartment, pairs, args.repeat)
    results["apartment"]["map"] = f"{apartment.size_x} x {apartment.size_y} cells at {apartment.resolution} m"
    results["apartment"]["costmap_update_ms"] = update_ms

    rng = np.random.default_rng(args.seed)
    big, big_update_ms = global_costmap(params, synthetic_map(args.big_size, args.seed), 0.05)
    pts = free_points(big, rng, 4 * args.big_plans, margin=5)
    # far-apart pairs: of random candidates, keep the ones at least half the map's side apart
    side = big.size_x * big.resolution
    big_pairs = [(a, b) for a, b in zip(pts[0::2], pts[1::2], strict=True) if math.dist(a, b) > 0.5 * side]
    big_pairs = [((*a, 0.0), (*b, 0.0)) for a, b in big_pairs[: args.big_plans]]
    planner.make_plan(big, *big_pairs[0])  # warm-up at this size (allocation)
    results["synthetic_2000"] = run_case(planner, big, big_pairs, 1)
    results["synthetic_2000"]["map"] = f"{big.size_x} x {big.size_y} cells at {big.resolution} m, seed {args.seed}"
    results["synthetic_2000"]["costmap_update_ms"] = big_update_ms

    results["local_planner"] = local_planner_case(params, args.cycles)
    results["local_planner"]["target_ms_p99"] = LOCAL_TARGET_MS

    for case in ("apartment", "synthetic_2000"):
        r = results[case]
        verdict = "ok" if r["p50_ms"] <= TARGETS_MS[case] else "OVER TARGET"
        print(f"{case:15s} p50 {r['p50_ms']:8.2f} ms  p99 {r['p99_ms']:8.2f} ms  max {r['max_ms']:8.2f} ms  "
              f"(CPU p50 {r['cpu_p50_ms']:.2f}, p99 {r['cpu_p99_ms']:.2f} ms)  "
              f"n {r['n']:3d}  ({r['map']}; costmap update {r['costmap_update_ms']:.0f} ms; "
              f"target p50 <= {TARGETS_MS[case]:.0f} ms: {verdict})")
        for f in r["failures"]:
            print(f"    failed: {f}")
    r = results["local_planner"]
    verdict = "ok" if r["p99_ms"] <= LOCAL_TARGET_MS else "OVER TARGET"
    print(f"{'local_planner':15s} p50 {r['p50_ms']:8.2f} ms  p99 {r['p99_ms']:8.2f} ms  max {r['max_ms']:8.2f} ms  "
          f"(CPU p50 {r['cpu_p50_ms']:.2f}, p99 {r['cpu_p99_ms']:.2f} ms)  n {r['n']:3d}  "
          f"({r['samples']} samples, {r['costmap']}; target p99 <= {LOCAL_TARGET_MS:.0f} ms: {verdict})")
    print(f"numba compile (fresh, uncached) {compile_s:.2f} s; first plan (compile or cache load) {first_call:.2f} s")
    results["load_average_1min"] = os.getloadavg()[0]
    print(f"load average (1 min) {results['load_average_1min']:.1f}: wall times include waiting for a core")
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
