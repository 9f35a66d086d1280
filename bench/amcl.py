"""amcl benchmark: accuracy on a tour of the simulated apartment, global localization, update time, memory.

    source devel/setup.bash && /usr/bin/python3 bench/amcl.py [--length 30] [--rtf 3] [--seed 1]

Runs florence_sim (apartment, no people unless --with-people), map_server with maps/apartment/apartment.yaml and
amcl with turtlebot_control/config/amcl_turtlebot_control.launch (the values that ship)
on a private master, drives the robot along a scripted tour with ground truth at 0.3 m/s,
and compares amcl_pose with ground truth at each estimate's time stamp:

1. tracking: the tour of --length metres from the known start pose; RMS position and yaw
   errors after convergence (targets: <= 0.05 m, <= 2 deg);
2. global localization: --global-trials times, global_localization where the robot is, then
   on along the tour (at most --global-max m); distance travelled until the estimate stays
   within 0.2 m / 10 deg (target: <= 10 m); the true pose is re-sent as initialpose between trials;
3. update time: in-process, Localizer with exactly 500 particles and 60 beams on the
   apartment map fed the recorded-like scans (target p99 <= 20 ms), and the node's own
   update durations during the tour;
4. memory: the amcl process's resident set (VmRSS, peak VmHWM).

Writes bench/results/amcl.json and bench/results/amcl.png (estimated vs true path over the map).

    /usr/bin/python3 bench/amcl.py --offline [--seeds 1,2,3] [--length 30] [--global-seeds 1,2]

runs the same tour and global localizations without ROS (florence_eval.amcl_offline: florence_sim's core and the
amcl core in one process, the launch file's values, repeatable per seed) and writes
bench/results/amcl_offline.json: per seed the position / yaw RMS after convergence and the mean error
along and across the heading (the bias), per start the distance to converge, and the update time of step 3.
The runs themselves are florence_eval.amcl_bench's.
"""

import argparse
import json
import sys
from pathlib import Path

# This file is called amcl.py: keep its directory off the import path so that `amcl` is the package.
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
RESULTS = Path(__file__).resolve().parent / "results"


def seeds(text):
    return [int(s) for s in text.split(",") if s]


def main():
    from florence_eval import amcl_bench

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--length", type=float, default=30.0, help="tour length [m]")
    parser.add_argument("--rtf", type=float, default=3.0, help="simulator real-time factor")
    parser.add_argument("--seed", type=int, default=1, help="simulator noise seed")
    parser.add_argument("--with-people", action="store_true", help="the apartment's two walking people")
    parser.add_argument("--global-max", type=float, default=15.0, help="longest drive per global localization [m]")
    parser.add_argument("--global-trials", type=int, default=3, help="global localization trials")
    parser.add_argument("--offline", action="store_true", help="in-process evaluation without ROS")
    parser.add_argument("--seeds", default="1,2,3", help="--offline: simulator seeds of the tracking runs")
    parser.add_argument("--global-seeds", default="1,2", help="--offline: seeds of the global runs (8 starts each)")
    args = parser.parse_args()
    command = "bench/amcl.py " + " ".join(sys.argv[1:])
    RESULTS.mkdir(parents=True, exist_ok=True)
    if args.offline:
        result = amcl_bench.offline(seeds(args.seeds), args.length, seeds(args.global_seeds), args.global_max,
                                    command)
        out = RESULTS / "amcl_offline.json"
    else:
        result = amcl_bench.ros_run(args.length, args.rtf, args.seed, args.with_people, args.global_max,
                                    args.global_trials, RESULTS, command)
        print(json.dumps(result, indent=2))
        out = RESULTS / "amcl.json"
    out.write_text(json.dumps(result, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
