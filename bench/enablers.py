"""Robot enablers benchmark: follow_me and approach_me in florence_sim with the real user tracker,
through the collision monitor, judged against the simulator's ground truth.

    source devel/setup.bash && /usr/bin/python3 bench/enablers.py [--rtf 1.0] [--follows 3] [--approaches 20]

What a user runs (florence_eval/launch/enablers_sim.launch): florence_sim's apartment, the filters
with the collision monitor, the Kinect's fake laser, map_server and amcl, user_tracker.launch,
follow_me and approach_me; nobody but the bench's person. The goals are sent as a client would,
with the person's position in the robot frame (taken from the simulator: it stands for
detect_users); nothing of the ground truth reaches the product.

1. Following: a person walks at --speed (0.5 m/s) from the living room through the doorway into
   the corridor and along it (two rooms and a doorway), the robot starting 1.8 m behind with a
   FollowMe goal (1 m), closing in to 1 m before they set off; judged from the moment they set off
   until the robot settled behind them after they stopped: RMS of the centre distance minus 1 m
   (target <= 0.15 m; beside it, what a perfect follower at the Create's limits, 0.5 m/s and
   1 m/s^2, would have had seeing them 0, 0.1, 0.3 and 0.6 s late, driving straight at the person, and
   keeping to their trail as follow_me does: at the walker's own speed, ground lost is lost for the
   walk, unless a corner is cut), the least centre
   distance (>= 0.45 m), the share of the time follow_me had the right person (>= 98 %), bumper
   contacts (0). The same at 0.3 m/s for reference.
2. Approaching: --approaches random placements (florence_eval.enablers_metrics.random_approach: the
   robot anywhere free, a person standing 1.5-2.2 m in front of it, distance 0.5-0.9 m, p2r within
   +-120 degrees, r2p within +-0.5 rad, a way clear of the furniture): SUCCEEDED (>= 19 of 20),
   final position error <= 0.10 m and heading error <= 0.1 rad by ground truth, 0 contacts.
3. The collision monitor's added latency per command: the wall time from a command leaving the
   multiplexer to its judgement leaving the monitor, as this process receives both (p50 / p99),
   and the node's own time to judge one (its /diagnostics).

Writes bench/results/enablers.json and bench/results/enablers.png (paths over the map).
"""

import argparse
import json
import math
import os
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
TARGETS = {"follow_rms_error_m": 0.15, "follow_min_distance_m": 0.45, "follow_kept_fraction": 0.98,
           "follow_collisions": 0, "approach_succeeded_of_20": 19, "approach_position_error_m": 0.10,
           "approach_heading_error_rad": 0.10, "approach_collisions": 0}
RED = [0.85, 0.1, 0.1]
# living room -> corridor through the door at x 2.0..2.9 (y 5.5), then east along the corridor
FOLLOW_PATH = [[1.2, 3.8], [2.45, 4.9], [2.45, 6.15], [6.0, 6.15]]
FOLLOW_START = (1.2, 2.0, math.pi / 2)


def monitor_judge_time(timeout=10.0):
    """The collision monitor's 'judge time p50 / p99 (ms)' from /diagnostics, or None."""
    import rospy
    from diagnostic_msgs.msg import DiagnosticArray

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = rospy.wait_for_message("/diagnostics", DiagnosticArray, timeout)
        for status in msg.status:
            if "Collision monitor" in status.name:
                values = {v.key: v.value for v in status.values}
                return values.get("judge time p50 / p99 (ms)")
    return None


def held_text(held):
    """"; the collision monitor first held it back ..." for a failed approach's ``monitor_held`` ("" for None)."""
    if not held:
        return ""
    return (f"; the collision monitor first held it back at {held['t']} s: {held['reason']}, nearest point "
            f"({held['nearest'][0]:.2f}, {held['nearest'][1]:.2f}) in the map")


def summary(follows, approaches, latency_ms, judge):
    out = {}
    for speed in sorted({f["speed"] for f in follows}):
        runs = [f for f in follows if f["speed"] == speed]
        out[f"follow_{speed}"] = {
            "runs": len(runs),
            "rms_error_m": float(np.sqrt(np.mean([f["rms_error_m"] ** 2 for f in runs]))),
            "rms_error_m_each": [round(f["rms_error_m"], 3) for f in runs],
            # a perfect follower (enablers_metrics.ideal_following) seeing the person so many seconds late
            "ideal_rms_error_m": {k: float(np.sqrt(np.mean([f["ideal_rms_error_m"][k] ** 2 for f in runs])))
                                  for k in runs[0]["ideal_rms_error_m"]},
            # ... and one that keeps to the person's trail (through the doorway they took, as follow_me)
            "ideal_trail_rms_error_m": {k: float(np.sqrt(np.mean([f["ideal_trail_rms_error_m"][k] ** 2
                                                                   for f in runs])))
                                        for k in runs[0]["ideal_trail_rms_error_m"]},
            "mean_distance_m": float(np.mean([f["mean_distance_m"] for f in runs])),
            "min_distance_m": float(min(f["min_distance_m"] for f in runs)),
            "kept_fraction": float(np.mean([f["kept_fraction"] for f in runs])),
            "collisions": int(sum(f["collisions"] for f in runs)),
            "goals_still_active": sum(f["state"] == "ACTIVE" for f in runs),
            "tracker_drops": [f["tracker_drops"] for f in runs],
        }
    ok = [a for a in approaches if a["state"] == "SUCCEEDED"]
    out["approach"] = {
        "placements": len(approaches),
        "succeeded": len(ok),
        "position_error_m_max": float(max(a["position_error_m"] for a in ok)) if ok else None,
        "position_error_m_median": float(np.median([a["position_error_m"] for a in ok])) if ok else None,
        "heading_error_rad_max": float(max(a["heading_error_rad"] for a in ok)) if ok else None,
        "heading_error_rad_median": float(np.median([a["heading_error_rad"] for a in ok])) if ok else None,
        "within_0.10_m_and_0.1_rad": sum(a["position_error_m"] <= 0.10 and a["heading_error_rad"] <= 0.10
                                         for a in ok),
        "collisions": int(sum(a["collisions"] for a in approaches)),
        "least_person_distance_m": float(min(a["least_distance_m"] for a in approaches)) if approaches else None,
        "failures": [f"{a['state']}: {a['text']}{held_text(a.get('monitor_held'))}" for a in approaches
                     if a["state"] != "SUCCEEDED"],
    }
    from florence_eval.enablers_metrics import percentiles

    out["monitor_latency_ms"] = {**percentiles(latency_ms), "commands": len(latency_ms), "judge_time_node": judge}
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rtf", type=float, default=1.0, help="simulator real-time factor")
    parser.add_argument("--seed", type=int, default=1, help="placement and simulator noise seed")
    parser.add_argument("--speed", type=float, default=0.5, help="the followed person's speed [m/s]")
    parser.add_argument("--follows", type=int, default=3, help="following runs at --speed (and one at 0.3 m/s)")
    parser.add_argument("--approaches", type=int, default=20, help="random approach placements")
    args = parser.parse_args()

    import rospy
    from florence_eval.enablers_session import EnablersSession, launch_stack
    from map_server.mapfile import load_map

    from florence_common.maps import map_file
    from florence_common.processes import RosMaster
    from florence_eval import enablers_metrics, nav_metrics

    RESULTS.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    master = RosMaster().start()
    os.environ.update({k: v for k, v in master.env().items() if k.startswith("ROS_")})
    proc = launch_stack(master, FOLLOW_START, real_time_factor=args.rtf, seed=args.seed)
    follows, approaches = [], []
    load = [os.getloadavg()[0]]
    try:
        rospy.init_node("bench_enablers", disable_signals=True)
        session = EnablersSession()
        session.wait_ready()
        for k, speed in enumerate([args.speed] * args.follows + [0.3]):
            result = session.follow_trial(FOLLOW_START, "alice", FOLLOW_PATH, speed, RED)
            session.follow_client.cancel_goal()
            follows.append({**result, "speed": speed})
            load.append(os.getloadavg()[0])
            ideal = ", ".join(f"{v:.3f} m ({k} late)" for k, v in result["ideal_rms_error_m"].items())
            trail = ", ".join(f"{v:.3f} m ({k} late)" for k, v in result["ideal_trail_rms_error_m"].items())
            print(f"follow {k + 1} at {speed} m/s: RMS {result['rms_error_m']:.3f} m (a perfect follower straight at "
                  f"her: {ideal}; on her trail: {trail}), "
                  f"mean {result['mean_distance_m']:.2f} m, least {result['min_distance_m']:.2f} m, kept "
                  f"{result['kept_fraction']:.1%}, "
                  f"{result['collisions']} contacts, {result['state']}; "
                  f"tracker drops {result['tracker_drops'] or 'none'}", flush=True)
        scene = nav_metrics.load_scene()
        for k in range(args.approaches):
            place = enablers_metrics.random_approach(scene, rng)
            try:
                result = session.approach_trial(place["robot"], "alice", place["person"], RED, place["distance"],
                                                place["p2r"], place["r2p"])
            except RuntimeError as exc:  # the person was not tracked: the placement is not judged
                print(f"approach {k + 1}: skipped: {exc}", flush=True)
                continue
            approaches.append(result)
            load.append(os.getloadavg()[0])
            print(f"approach {k + 1}: {result['state']} {result['position_error_m']:.3f} m, "
                  f"{result['heading_error_rad']:.3f} rad, {result['seconds']:.0f} s ({result['text']})"
                  f"{held_text(result['monitor_held'])}", flush=True)
        latency = enablers_metrics.latency(session.commands_log("mux"), session.commands_log("monitor"))
        judge = monitor_judge_time()
        result = summary(follows, approaches, 1e3 * latency, judge)
        result.update({"targets": TARGETS, "rtf": args.rtf, "seed": args.seed,
                       "load_average_1min": {"min": min(load), "max": max(load), "mean": float(np.mean(load))},
                       "cpus": os.cpu_count()})
        (RESULTS / "enablers.json").write_text(json.dumps({**result, "follows": follows, "approaches": approaches},
                                                          indent=1))
        grid = load_map(str(map_file("apartment", "apartment.yaml")))
        enablers_metrics.plot(RESULTS / "enablers.png", grid, follows, approaches,
                              f"bench/enablers.py seed {args.seed}, rtf {args.rtf}")
        print(json.dumps(result, indent=2))
        print(f"wrote {RESULTS / 'enablers.json'} and {RESULTS / 'enablers.png'}")
    finally:
        proc.stop()
        master.stop()


if __name__ == "__main__":
    main()
