"""Gyro calibration benchmark: accuracy of turtlebot_calibration over injected gyro scale errors.

    source devel/setup.bash && /usr/bin/python3 bench/calibration.py [--errors -0.1,...,0.1] [--seeds 1,2,3]
        [--no-people]

For every injected error and seed, turtlebot_calibration's Calibrator (the product's procedure
with its default settings) runs on florence_sim's core in the shipped apartment, with its walking
people, from calibration_control.launch sim:=true's start (facing the living room's west wall),
through the upside-down Hokuyo (florence_eval.calibration_offline). Then, as the user manual says,
again with the printed factor applied (the simulated gyro's error becomes (1 + e) x factor - 1).

Figures: the printed gyro factor against the truth 1 / (1 + e) (target: within 1 %), the second
run's factor against 1 (target: within 1 %), simulated and CPU time per calibration. Writes
bench/results/calibration.json and bench/results/calibration.png.
"""

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"


def floats(text):
    return [float(s) for s in text.split(",") if s]


def main():
    from florence_eval.calibration_offline import calibrate, corrected_error

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--errors", default="-0.1,-0.08,-0.05,-0.02,0,0.02,0.05,0.08,0.1",
                        help="injected gyro scale errors (measured rate = true x (1 + e))")
    parser.add_argument("--seeds", default="1,2,3", help="simulator seeds")
    parser.add_argument("--no-people", action="store_true", help="the apartment without its walking people")
    args = parser.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    errors, seeds = floats(args.errors), [int(s) for s in args.seeds.split(",") if s]
    rows = []
    print(f"{'error':>7} {'seed':>4} {'factor':>9} {'truth':>9} {'off %':>7} {'2nd run':>8} {'off %':>7} "
          f"{'sim s':>6} {'cpu s':>6}")
    for e in errors:
        for seed in seeds:
            first = calibrate(e, seed, people=not args.no_people)
            row = {"injected_error": e, "seed": seed, "truth": first.truth, "factor": first.gyro_factor,
                   "odom_factor": first.odom_factor, "error_percent": None, "sim_s": first.sim_seconds,
                   "cpu_s": first.cpu_seconds, "failure": first.error, "second": None}
            if first.gyro_factor is not None:
                row["error_percent"] = 100.0 * first.gyro_factor_error
                second = calibrate(corrected_error(e, first.gyro_factor), seed + 100, people=not args.no_people)
                row["second"] = {"factor": second.gyro_factor, "off_percent": None if second.gyro_factor is None
                                 else 100.0 * (second.gyro_factor - 1.0), "failure": second.error,
                                 "sim_s": second.sim_seconds, "cpu_s": second.cpu_seconds}
            rows.append(row)
            s = row["second"] or {}
            print(f"{e:+7.3f} {seed:4d} {_f(row['factor'], 9, 6)} {row['truth']:9.6f} {_f(row['error_percent'], 7, 3)} "
                  f"{_f(s.get('factor'), 8, 5)} {_f(s.get('off_percent'), 7, 3)} {row['sim_s']:6.1f} "
                  f"{row['cpu_s']:6.1f}" + (f"  FAILED: {row['failure']}" if row["failure"] else ""))
            sys.stdout.flush()
    ok = [r for r in rows if r["error_percent"] is not None]
    worst = max((abs(r["error_percent"]) for r in ok), default=None)
    second = [r["second"]["off_percent"] for r in ok if r["second"] and r["second"]["off_percent"] is not None]
    worst_second = max((abs(v) for v in second), default=None)
    summary = {
        "runs": len(rows), "failed": len(rows) - len(ok),
        "worst_factor_error_percent": worst,
        "rms_factor_error_percent": (statistics.fmean(r["error_percent"] ** 2 for r in ok) ** 0.5) if ok else None,
        "worst_second_run_off_percent": worst_second,
        "within_1_percent": sum(abs(r["error_percent"]) <= 1.0 for r in ok),
        "second_within_1_percent": sum(abs(v) <= 1.0 for v in second),
        "median_sim_s": statistics.median(r["sim_s"] for r in rows),
        "median_cpu_s": statistics.median(r["cpu_s"] for r in rows),
    }
    print(f"\n{summary['within_1_percent']} of {len(rows)} first runs within 1 % of the truth (worst "
          f"{_f(worst, 0, 3)} %, rms {_f(summary['rms_factor_error_percent'], 0, 3)} %); second runs within 1 % "
          f"of 1: {summary['second_within_1_percent']} of {len(second)} (worst {_f(worst_second, 0, 3)} %); "
          f"median {summary['median_sim_s']:.0f} simulated s, {summary['median_cpu_s']:.1f} CPU s per calibration")
    out = {"bench": "calibration", "command": "bench/calibration.py " + " ".join(sys.argv[1:]),
           "time": time.strftime("%Y-%m-%dT%H:%M:%S"), "loadavg": os.getloadavg(), "machine": platform.node(),
           "people": not args.no_people, "laser": "hokuyo (offline)", "summary": summary, "runs": rows}
    (RESULTS / "calibration.json").write_text(json.dumps(out, indent=1))
    plot(rows, RESULTS / "calibration.png")
    print(f"wrote {RESULTS / 'calibration.json'} and calibration.png")
    return 0 if summary["failed"] == 0 and worst is not None and worst <= 1.0 else 1


def _f(value, width, digits):
    return f"{'-':>{width}}" if value is None else f"{value:{width}.{digits}f}"


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    ok = [r for r in rows if r["error_percent"] is not None]
    ax.scatter([100 * r["injected_error"] for r in ok], [r["error_percent"] for r in ok], label="first run vs truth")
    second = [r for r in ok if r["second"] and r["second"]["off_percent"] is not None]
    ax.scatter([100 * r["injected_error"] + 0.3 for r in second], [r["second"]["off_percent"] for r in second],
               marker="x", label="second run (corrected) vs 1")
    ax.axhspan(-1, 1, color="green", alpha=0.1, label="target +-1 %")
    ax.axhline(0, color="grey", lw=0.5)
    ax.set_xlabel("injected gyro scale error [%]")
    ax.set_ylabel("printed factor off by [%]")
    ax.set_title("turtlebot_calibration in florence_sim (apartment, Hokuyo)")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
