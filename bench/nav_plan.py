"""Benchmark of move_base's navfn global planner (move_base.navfn.NavfnPlanner.make_plan).

Run from the workspace root (no ROS needed):
    PYTHONPATH=src/move_base/src /usr/bin/python3 bench/nav_plan.py [--repeat 5] [--big-plans 4]
(or after `source devel/setup.bash`). Prints the figures and writes bench/results/nav_plan.json.

Cases:
- apartment: maps/apartment/apartment.yaml as a global costmap (occupied -> LETHAL, unknown ->
  NO_INFORMATION, inflated with costmap_2d's formula: inscribed radius 0.18 m, inflation
  radius 0.40 m, cost_scaling_factor 10), plans between every ordered pair of room hotspots
  of maps/apartment/rooms.yaml. Target p50 <= 30 ms.
- synthetic: a 2000 x 2000 cell (100 m x 100 m at 0.05 m) map with random rectangular obstacles,
  inflated the same way, plans between far-apart free points. Target p50 <= 1 s.
numba's compile time is reported separately (``compile_s``: a fresh, uncached compile of the
planner's jitted functions; ``first_call_s``: the first plan, which loads numba's on-disk cache
when there is one); the timings exclude it (one warm-up plan first).
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import yaml
from PIL import Image
from scipy.ndimage import distance_transform_edt

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src" / "move_base" / "src"))

from move_base.costmap_2d import (  # noqa: E402
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap2D,
)

from move_base import navfn  # noqa: E402

RESULTS = ROOT / "bench" / "results" / "nav_plan.json"
MAP_YAML = ROOT / "maps" / "apartment" / "apartment.yaml"
ROOMS_YAML = ROOT / "maps" / "apartment" / "rooms.yaml"
TARGETS_MS = {"apartment": 30.0, "synthetic_2000": 1000.0}
INSCRIBED_RADIUS = 0.18  # [m]
INFLATION_RADIUS = 0.40  # [m]
COST_SCALING_FACTOR = 10.0  # [1/m]


def inflate(lethal, unknown, resolution):
    """costmap_2d's inflation of a boolean lethal mask: 254 on lethal cells, 253 within the
    inscribed radius, ``252 * exp(-k (d - r_inscribed))`` out to the inflation radius [m]."""
    d = distance_transform_edt(~lethal) * resolution  # [m] to the nearest lethal cell centre
    costs = np.where(unknown, NO_INFORMATION, FREE_SPACE).astype(np.int64)
    ring = (d <= INFLATION_RADIUS) & ~lethal
    decay = ((INSCRIBED_INFLATED_OBSTACLE - 1) * np.exp(-COST_SCALING_FACTOR * (d - INSCRIBED_RADIUS))).astype(np.int64)
    inflated = np.where(d <= INSCRIBED_RADIUS, INSCRIBED_INFLATED_OBSTACLE, decay)
    # costmap_2d's InflationLayer (inflate_unknown false): an unknown cell takes the inflation cost
    # only when it is >= INSCRIBED, a known one the larger of both
    is_unknown = costs == NO_INFORMATION
    raise_known = ring & ~is_unknown & (inflated > costs)
    raise_unknown = ring & is_unknown & (inflated >= INSCRIBED_INFLATED_OBSTACLE)
    costs = np.where(raise_known | raise_unknown, inflated, costs)
    costs[lethal] = LETHAL_OBSTACLE
    return costs.astype(np.uint8)


def load_map(path):
    """Costmap2D of a map_server YAML + PGM (trinary: occupied / free / unknown)."""
    meta = yaml.safe_load(Path(path).read_text())
    img = np.asarray(Image.open(Path(path).parent / meta["image"]).convert("L"), dtype=float)
    p = (255.0 - img) / 255.0 if not meta.get("negate", 0) else img / 255.0  # occupancy probability
    p = p[::-1]  # image row 0 is the top (max y); costs[0] is the bottom row (min y)
    lethal = p > meta["occupied_thresh"]
    unknown = ~lethal & ~(p < meta["free_thresh"])
    res = float(meta["resolution"])
    cm = Costmap2D(p.shape[1], p.shape[0], res, meta["origin"][0], meta["origin"][1])
    cm.costs[...] = inflate(lethal, unknown, res)
    return cm


def synthetic_map(size, seed):
    rng = np.random.default_rng(seed)
    lethal = np.zeros((size, size), dtype=bool)
    n = size * size // 10000  # one obstacle per 100 x 100 cells on average
    for _ in range(n):
        x, y = rng.integers(0, size - 10, 2)
        w, h = rng.integers(3, 60, 2)
        lethal[y:y + h, x:x + w] = True
    cm = Costmap2D(size, size, 0.05)
    cm.costs[...] = inflate(lethal, np.zeros_like(lethal), cm.resolution)
    return cm


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


def run_case(planner, cm, pairs, repeat):
    samples, fails, lengths = [], [], []
    for _ in range(repeat):
        for start, goal in pairs:
            t0 = time.perf_counter()
            res = planner.make_plan(cm, start, goal)
            samples.append((time.perf_counter() - t0) * 1e3)
            if not res.ok:
                fails.append(f"{start[:2]} -> {goal[:2]}: {res.reason}")
            else:
                lengths.append(float(np.sum(np.hypot(*np.diff(res.poses[:, :2], axis=0).T))))
    s = np.array(samples)
    return {"p50_ms": float(np.percentile(s, 50)), "p99_ms": float(np.percentile(s, 99)), "max_ms": float(s.max()),
            "n": len(s), "cells": int(cm.costs.size), "failures": sorted(set(fails)),
            "mean_path_length_m": float(np.mean(lengths)) if lengths else None}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=5, help="passes over the apartment's room pairs")
    ap.add_argument("--big-size", type=int, default=2000, help="synthetic map side [cells]")
    ap.add_argument("--big-plans", type=int, default=6, help="plans on the synthetic map")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    planner = navfn.NavfnPlanner(allow_unknown=True, default_tolerance=0.0)
    apartment = load_map(MAP_YAML)
    rooms = yaml.safe_load(ROOMS_YAML.read_text())["rooms"]
    spots = {name: (r["hotspot"]["x"], r["hotspot"]["y"], r["hotspot"]["phi"]) for name, r in sorted(rooms.items())}
    pairs = [(spots[a], spots[b]) for a in spots for b in spots if a != b]

    t0 = time.perf_counter()
    planner.make_plan(apartment, *pairs[0])  # warm-up: numba compile or cache load
    first_call = time.perf_counter() - t0
    compile_s = compile_time()

    results = {"compile_s": compile_s, "first_call_s": first_call, "targets_ms_p50": TARGETS_MS}
    results["apartment"] = run_case(planner, apartment, pairs, args.repeat)
    results["apartment"]["map"] = f"{apartment.size_x} x {apartment.size_y} cells at {apartment.resolution} m"

    rng = np.random.default_rng(args.seed)
    big = synthetic_map(args.big_size, args.seed)
    pts = free_points(big, rng, 4 * args.big_plans, margin=5)
    # far-apart pairs: of random candidates, keep the ones at least half the map's side apart
    side = big.size_x * big.resolution
    big_pairs = [(a, b) for a, b in zip(pts[0::2], pts[1::2], strict=True) if math.dist(a, b) > 0.5 * side]
    big_pairs = [((*a, 0.0), (*b, 0.0)) for a, b in big_pairs[: args.big_plans]]
    planner.make_plan(big, *big_pairs[0])  # warm-up at this size (allocation)
    results["synthetic_2000"] = run_case(planner, big, big_pairs, 1)
    results["synthetic_2000"]["map"] = f"{big.size_x} x {big.size_y} cells at {big.resolution} m, seed {args.seed}"

    for case in ("apartment", "synthetic_2000"):
        r = results[case]
        verdict = "ok" if r["p50_ms"] <= TARGETS_MS[case] else "OVER TARGET"
        print(f"{case:15s} p50 {r['p50_ms']:8.2f} ms  p99 {r['p99_ms']:8.2f} ms  max {r['max_ms']:8.2f} ms  "
              f"n {r['n']:3d}  ({r['map']}; target p50 <= {TARGETS_MS[case]:.0f} ms: {verdict})")
        for f in r["failures"]:
            print(f"    failed: {f}")
    print(f"numba compile (fresh, uncached) {compile_s:.2f} s; first plan (compile or cache load) {first_call:.2f} s")
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
