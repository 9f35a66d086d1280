"""move_base benchmark: random goals in the simulated apartment with the whole navigation stack.

    source devel/setup.bash && /usr/bin/python3 bench/nav.py [--pairs 100] [--rtf 2.5] [--seed 1]

Starts turtlebot_2dnav_control.launch sim:=true (florence_sim without people, the filters,
map_server, amcl, move_base with the seed's parameters) on a private master and sends the robot
to --pairs random goals in a row (each leg is one pair: from where the robot is to a random pose
at least --clearance m from the walls and furniture of florence_sim's keep-out map, the map
move_base plans on, reachable by ~make_plan).
For each leg: outcome, simulated time, the planned (shortest) path length from move_base's
~make_plan, the driven length, collisions from the simulator's bumpers, the least ground-truth
gap between the robot's body and the world, and where the time went (driving, turning on the
spot, standing still): florence_eval.nav_metrics. ``--clearance-of nav.json`` prints those gaps
for a saved run.

Figures and targets (issue 6): success >= 98 %, collisions 0, median time-to-goal <= 1.3 x
(plan length / max_vel_x); the ratio with the two turns of each leg added
(time_ratio_with_turns_median, see florence_eval.nav_metrics); move_base's CPU use at the seed's
controller_frequency (5 Hz) from /proc. Writes bench/results/nav.json and bench/results/nav.png
(every trajectory over the map).
"""

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from florence_eval import nav_metrics

RESULTS = Path(__file__).resolve().parent / "results"
START = (1.0, 2.5, 0.0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--pairs", type=int, default=100, help="random goals to drive to, one after the other")
    parser.add_argument("--rtf", type=float, default=2.5, help="simulator real-time factor")
    parser.add_argument("--seed", type=int, default=1, help="goal and simulator noise seed")
    parser.add_argument("--clearance", type=float, default=0.4, help="least distance of a goal from obstacles [m]")
    parser.add_argument("--leg-timeout", type=float, default=180.0, help="simulated seconds per goal")
    parser.add_argument("--clearance-of", metavar="JSON", help="only print the body clearances of a saved nav.json")
    args = parser.parse_args()
    if args.clearance_of:
        try:
            print(json.dumps(nav_metrics.clearance_of(args.clearance_of), indent=1))
        except (OSError, ValueError) as exc:
            raise SystemExit(f"--clearance-of {args.clearance_of}: {exc}") from None
        return

    from florence_eval.metrics import cpu_seconds, node_pid

    from florence_common.processes import RosMaster, roslaunch, wait_for

    RESULTS.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    master = RosMaster().start()
    os.environ.update({k: v for k, v in master.env().items() if k.startswith("ROS_")})
    nobody = Path(master.ros_home) / "nobody.yaml"
    nobody.write_text("people: []\n")
    stack = roslaunch(master, "turtlebot_control", "turtlebot_2dnav_control.launch", "sim:=true",
                      f"people:={nobody}", f"real_time_factor:={args.rtf}", f"seed:={args.seed}",
                      f"x:={START[0]}", f"y:={START[1]}", f"yaw:={START[2]}")
    try:
        import rospy
        from florence_eval.nav_session import NavSession
        from map_server.node import msg_to_grid
        from nav_msgs.msg import OccupancyGrid

        rospy.init_node("bench", anonymous=False, disable_signals=True)
        session = NavSession()
        if not session.wait_ready(180.0):
            raise SystemExit(f"move_base did not come up:\n{stack.output()}")
        wait_for(lambda: session.sim_now() > 3.0, 60, what="the simulation to run")
        time.sleep(1.0)
        # goals come from the map move_base plans on: florence_sim's keep-out map (table tops and
        # chair seats marked), so no goal is under a table
        grid = msg_to_grid(rospy.wait_for_message("/florence_sim/keepout_map", OccupancyGrid, timeout=60))
        pid = node_pid(master.uri, "/move_base")
        scene, body = nav_metrics.load_scene(), nav_metrics.robot_body()
        legs = []
        goals = nav_metrics.random_goals(grid, args.pairs * 3, args.clearance, rng)
        cpu0, sim0, wall0 = cpu_seconds(pid), session.sim_now(), time.monotonic()
        for goal in goals:
            if len(legs) >= args.pairs:
                break
            here = session.latest()
            start = (here[1], here[2], here[3])
            xy = session.plan(start, goal)
            if xy is None:
                continue  # not reachable from here (a closed-off corner)
            plan_m, turns_s = nav_metrics.plan_length_and_turns(xy, start, goal)
            if plan_m < 0.5:
                continue  # no real leg
            collisions_before, poses_before = session.collisions, len(session.collision_poses)
            t0 = session.sim_now()
            state, text, took, driven = session.go(*goal, sim_timeout=args.leg_timeout)
            # move_base ends a goal once within its tolerances (TrajectoryPlannerROS); the base may
            # still be braking then. Each leg starts from rest, and the bench says when rest came.
            session.wait_still(sim_time=0.3)
            legs.append(nav_metrics.leg_record(
                goal, state, text, took, driven, plan_m, turns_s, session.track(since=t0), t0,
                session.collisions - collisions_before, session.collision_poses[poses_before:], scene, body))
            leg = legs[-1]
            print(f"{len(legs):3d}: {state:9s} {took:6.1f} s plan {plan_m:5.2f} m ratio {leg['ratio']:4.2f} "
                  f"(at rest {leg['rest_s'] - took:+.1f} s) {text if state != 'SUCCEEDED' else ''}", flush=True)
        cpu = cpu_seconds(pid) - cpu0
        sim_total, wall_total = session.sim_now() - sim0, time.monotonic() - wall0

        result = {
            **nav_metrics.summarise(legs),
            "move_base_cpu_fraction": cpu / wall_total, "move_base_cpu_s_per_sim_s": cpu / sim_total,
            "sim_time_s": sim_total, "wall_time_s": wall_total, "rtf": args.rtf, "seed": args.seed,
            "load_average_1min": os.getloadavg()[0],
        }
        nav_metrics.plot_legs(
            RESULTS / "nav.png", grid, legs,
            f"move_base: {result['succeeded']}/{len(legs)} goals, {result['collisions']} collisions, median "
            f"time/ideal {result['time_ratio_median'] or float('nan'):.2f}")
        (RESULTS / "nav.json").write_text(json.dumps({**result, "legs": legs}, indent=1))
        print(json.dumps(result, indent=2))
        print(f"wrote {RESULTS / 'nav.json'} and {RESULTS / 'nav.png'}")
        session.close()
    finally:
        stack.stop()
        master.stop()


if __name__ == "__main__":
    main()
