"""florenceLocator benchmark: gotoUser over random placements of the user and the robot in the
simulated apartment, with the whole stack.

    source devel/setup.bash && nice -n 10 /usr/bin/python3 bench/locator.py [--runs 20] [--rtf 2] [--seed 1]
        [--user-xy] [--no-people-layers]

Starts what the robot runs (florence_eval.locator_session.launch_stack: turtlebot_2dnav_control.launch
sim:=true with its user tracker and move_base's people layers, as shipped; florence_locator.launch) on a
private master. --no-people-layers: move_base without them (the tracker started apart), as the locator
was first built and measured against (reported apart). Each run places the user
in a random room (standing or sitting, facing anywhere, at least 0.55 m from furniture and 0.6 m from
the room's hotspot) and the robot in another room, tells the locator the user's room as a home
sensor would (setUserPosRoom; --user-xy: the user's true pose through setUserPosXYPhi, help from
ground truth reported apart) and calls gotoUser. Judged by ground truth (florence_eval.locator_bench):
outcome, final distance to the user, facing error, where the robot stands seen from the user (front,
front-left/right, side, behind), the least distance to any person over the run and over the approach,
collisions, simulated time.

Targets (issue 20): >= 95 % SUCCEEDED, final distance 0.5 +/- 0.15 m, facing error <= 20 deg,
never nearer than 0.45 m to any person, 0 collisions; median and p90 time per gotoUser. Writes
bench/results/locator.json and bench/results/locator.png (every run's path to the user), and what
the stack printed in bench/results/locator_logs/.
"""

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=20, help="random placements, one gotoUser each")
    parser.add_argument("--rtf", type=float, default=2.0, help="simulator real-time factor")
    parser.add_argument("--seed", type=int, default=1, help="placement and simulator noise seed")
    parser.add_argument("--user-xy", action="store_true", help="tell the locator the user's true pose "
                        "(setUserPosXYPhi) instead of the room (setUserPosRoom): help from ground truth")
    parser.add_argument("--run-timeout", type=float, default=300.0, help="simulated seconds per gotoUser")
    parser.add_argument("--no-people-layers", dest="people_layers", action="store_false",
                        help="move_base without its people layers (not the shipped configuration)")
    args = parser.parse_args()

    from florence_eval.locator_session import LocatorSession, launch_stack, stop_stack
    from florence_locator.places import Rooms

    from florence_common.maps import map_file
    from florence_common.processes import RosMaster
    from florence_eval import locator_bench

    RESULTS.mkdir(parents=True, exist_ok=True)
    name = ("locator_user_xy" if args.user_xy else "locator") + ("" if args.people_layers else "_no_people_layers")
    rng = np.random.default_rng(args.seed)
    rooms = Rooms.load(map_file("apartment", "rooms.yaml"))
    master = RosMaster().start()
    os.environ.update({k: v for k, v in master.env().items() if k.startswith("ROS_")})
    start = rooms.hotspots["kitchen"].as_tuple()
    procs = launch_stack(master, start, real_time_factor=args.rtf, seed=args.seed, people_layers=args.people_layers)
    try:
        import rospy
        from map_server.node import msg_to_grid
        from nav_msgs.msg import OccupancyGrid

        rospy.init_node("bench_locator", anonymous=False, disable_signals=True)
        session = LocatorSession()
        session.wait_ready()
        grid = msg_to_grid(rospy.wait_for_message("/florence_sim/keepout_map", OccupancyGrid, timeout=60))
        runs, loads = [], []
        sim0, wall0 = session.sim_now(), time.monotonic()
        for k, (room, user, robot) in enumerate(locator_bench.placements(rooms, grid, args.runs * 3, rng)):
            if len(runs) >= args.runs:
                break
            try:
                run = locator_bench.run_one(session, room, user, robot, args.user_xy, args.run_timeout)
            except RuntimeError as exc:  # florence_sim refused the placement (a person overlapping furniture)
                print(f"placement {k} skipped: {exc}", flush=True)
                continue
            runs.append(run)
            loads.append(os.getloadavg()[0])
            print(f"{len(runs):3d}: {run['state']:9s} {run['time_s']:6.1f} s ({run['wall_s']:.0f} s wall) "
                  f"{room:11s} {user['posture']:8s} d={run.get('distance_m', float('nan')):.2f} m "
                  f"facing {run.get('facing_error_deg', float('nan')):+5.1f} deg {run.get('side', ''):11s} "
                  f"nearest {run.get('nearest_person_m', float('nan')):.2f} m "
                  f"{run['text'] if run['state'] != 'SUCCEEDED' else ''}", flush=True)
        result = {
            **locator_bench.summarise(runs),
            "mode": "setUserPosXYPhi (ground truth)" if args.user_xy else "setUserPosRoom",
            "move_base_people_layers": args.people_layers,
            "sim_time_s": session.sim_now() - sim0, "wall_time_s": time.monotonic() - wall0,
            "rtf_asked": args.rtf, "seed": args.seed, "load_average_1min_median": float(np.median(loads)) if loads
            else None,
        }
        png = RESULTS / f"{name}.png"
        locator_bench.plot_runs(png, grid, runs, f"gotoUser ({result['mode']}): {result['succeeded']}/{len(runs)} "
                                f"SUCCEEDED, median {result['time_s_median'] or float('nan'):.0f} s")
        (RESULTS / f"{name}.json").write_text(json.dumps({**result, "runs_detail": runs}, indent=1))
        print(json.dumps(result, indent=2))
        print(f"wrote {RESULTS / (name + '.json')} and {png}")
        session.close()
    finally:
        stop_stack(procs)
        keep_logs(procs, RESULTS / f"{name}_logs")
        master.stop()


def keep_logs(procs, folder):
    """Copy what the stack's processes printed (roslaunch logs, stamped [wall, simulated] time: a run's
    'track' gives its simulated times) to ``folder``, replacing an earlier run's: the bench's master
    and its logs are temporary, and a run that went wrong was otherwise left unexplained."""
    import shutil

    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    for proc in procs:
        path = getattr(proc, "log_path", None)
        if path and os.path.exists(path):
            shutil.copy(path, folder / os.path.basename(path))
    print(f"the stack's logs in {folder}")


if __name__ == "__main__":
    main()
