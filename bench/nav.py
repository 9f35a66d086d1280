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
spot, standing still). ``--clearance-of nav.json`` prints those gaps for a saved run.

Figures and targets (issue 6): success >= 98 %, collisions 0, median time-to-goal <= 1.3 x
(plan length / max_vel_x). The goals' yaws are random, and each leg starts and ends with a
turn that even a perfect controller needs time for: the bench also reports the ratio to plan
length / max_vel_x plus those two turns at max_rotational_vel and velocity_filter's angular
acceleration (time_ratio_with_turns_median). move_base's CPU use at the seed's controller_frequency (5 Hz) from
/proc. Writes bench/results/nav.json and bench/results/nav.png (every trajectory over the map).
"""

import argparse
import json
import math
import os
import sys
import time
import xmlrpc.client
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
RESULTS = ROOT / "bench" / "results"
START = (1.0, 2.5, 0.0)
WORLD = ROOT / "maps" / "apartment" / "apartment.world.yaml"  # turtlebot_2dnav_control.launch's default
MAX_VEL_X = 0.5  # [m/s] the seed's TrajectoryPlannerROS max_vel_x
MAX_VEL_TH = 1.5  # [rad/s] the seed's max_rotational_vel
ACC_TH = 1.0  # [rad/s^2] velocity_filter's max_angular_acc, the base's real limit


def node_pid(master_uri, name):
    master = xmlrpc.client.ServerProxy(master_uri)
    _, _, uri = master.lookupNode("/bench", name)
    return xmlrpc.client.ServerProxy(uri).getPid("/bench")[2]


def cpu_seconds(pid):
    """User + system CPU time [s] of process ``pid``."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def random_goals(grid, count, clearance, rng):
    """``count`` poses (x, y, yaw) on free cells at least ``clearance`` [m] from any non-free cell."""
    from scipy.ndimage import distance_transform_edt

    free = grid.data == 0
    dist = distance_transform_edt(free) * grid.resolution
    rows, cols = np.nonzero(dist >= clearance)
    pick = rng.choice(len(rows), size=count, replace=True)
    x = grid.origin[0] + (cols[pick] + 0.5) * grid.resolution
    y = grid.origin[1] + (rows[pick] + 0.5) * grid.resolution
    return np.column_stack([x, y, rng.uniform(-math.pi, math.pi, count)])


def turn_time(angle):
    """Least time [s] to turn by ``angle`` [rad] from rest to rest within MAX_VEL_TH and ACC_TH."""
    angle = abs(math.atan2(math.sin(angle), math.cos(angle)))
    if angle <= MAX_VEL_TH**2 / ACC_TH:
        return 2.0 * math.sqrt(angle / ACC_TH)
    return MAX_VEL_TH / ACC_TH + angle / MAX_VEL_TH


def time_breakdown(track):
    """Simulated seconds (driving, turning on the spot, standing) of a ground-truth track
    (t, x, y, yaw, v, w)."""
    track = np.asarray(track)
    if len(track) < 2:
        return {"driving_s": 0.0, "turning_in_place_s": 0.0, "standing_s": 0.0}
    dt = np.diff(track[:, 0])
    v, w = np.abs(track[:-1, 4]), np.abs(track[:-1, 5])
    moving = v >= 0.03
    turning = ~moving & (w >= 0.05)
    return {"driving_s": float(dt[moving].sum()), "turning_in_place_s": float(dt[turning].sum()),
            "standing_s": float(dt[~moving & ~turning].sum())}


def time_to_rest(track, t0, v=0.01, w=0.01):
    """Simulated seconds from ``t0`` until the ground-truth track (t, x, y, yaw, v, w) came to rest
    for good (speeds within ``v`` [m/s] and ``w`` [rad/s] from then on)."""
    track = np.asarray(track)
    moving = np.nonzero((np.abs(track[:, 4]) > v) | (np.abs(track[:, 5]) > w))[0]
    if len(moving) == 0:
        return 0.0
    last = moving[-1]
    return float(track[min(last + 1, len(track) - 1), 0] - t0)


def leg_phases(track, goal, start_m=0.5, end_m=0.8):
    """Simulated seconds a leg's track (t, x, y, yaw, v, w) took for its first ``start_m`` [m]
    (until the robot was that far from where it started) and for its end (from the first time it
    came within ``end_m`` [m] of the goal to the last row). In a straight line from rest, at
    max_vel_x and acc_lim_x 0.5 m/s^2: 1.5 s and 2.1 s."""
    track = np.asarray(track)
    t = track[:, 0]
    away = np.nonzero(np.hypot(track[:, 1] - track[0, 1], track[:, 2] - track[0, 2]) > start_m)[0]
    near = np.nonzero(np.hypot(track[:, 1] - goal[0], track[:, 2] - goal[1]) < end_m)[0]
    start = t[away[0]] - t[0] if len(away) else t[-1] - t[0]
    end = t[-1] - t[near[0]] if len(near) else 0.0
    return {"start_s": float(start), "end_s": float(end)}


def goal_error(track, goal):
    """Ground-truth distance [m] and absolute yaw difference [rad] between the last row of a track
    (t, x, y, yaw, v, w) and the goal (x, y, yaw); None for an empty track."""
    if len(track) == 0:
        return None, None
    x, y, yaw = track[-1, 1:4]
    return float(math.hypot(goal[0] - x, goal[1] - y)), float(abs(math.remainder(goal[2] - yaw, 2 * math.pi)))


def error_spread(errors, tolerance):
    """Median, p90, max and the number beyond ``tolerance`` of the errors that are not None."""
    e = np.array([v for v in errors if v is not None], dtype=float)
    if len(e) == 0:
        return None
    return {"median": float(np.median(e)), "p90": float(np.percentile(e, 90)), "max": float(e.max()),
            "beyond_tolerance": int(np.sum(e > tolerance))}


def robot_body():
    """(radius, height) [m] of florence_sim's robot body: the Create's cylinder, and the top of
    the robot, below which an obstacle stops it (as the simulator builds them from the URDF)."""
    from florence_sim.node import base_dimensions
    from florence_sim.robot_model import RobotModel

    robot = RobotModel.from_xacro()
    return base_dimensions(robot)["radius"], robot.height()


def body_clearance(scene, track, radius, height):
    """Least ground-truth gap [m] between the robot's body (a cylinder of ``radius`` up to
    ``height``, what florence_sim's bumpers feel) and the world along a track (t, x, y, ...):
    about 0.005 m or less is a bumper contact; None for an empty track."""
    xy = np.asarray(track, dtype=float).reshape(-1, 6)[:, 1:3]
    if len(xy) == 0:
        return None
    dist, _ = scene.clearance(xy, z_max=height, z_min=0.0)
    return float(dist.min() - radius)


def clearance_spread(values):
    """Least, 5th percentile and median of the legs' least clearances [m]."""
    v = np.array([x for x in values if x is not None])
    if len(v) == 0:
        return None
    return {"min": float(v.min()), "p5": float(np.percentile(v, 5)), "median": float(np.median(v))}


def clearance_of(path):
    """Print the body clearances of the legs of a saved nav.json (from its saved tracks, every
    5th ground-truth pose, so the least gap may be a little smaller than printed)."""
    from florence_sim.world import load_world

    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise SystemExit(f"--clearance-of {path}: {exc}") from None
    scene = load_world(WORLD).scene
    radius, height = robot_body()
    per_leg = [body_clearance(scene, leg["track"], radius, height) for leg in data["legs"]]
    worst = sorted((c, i + 1) for i, c in enumerate(per_leg) if c is not None)[:5]
    print(json.dumps({"file": str(path), "body_clearance_m": clearance_spread(per_leg),
                      "closest_legs": [{"leg": i, "clearance_m": round(c, 4)} for c, i in worst]}, indent=1))


def plan_length(make_plan, start, goal):
    from geometry_msgs.msg import PoseStamped

    def pose(p):
        msg = PoseStamped()
        msg.header.frame_id = "map"
        msg.pose.position.x, msg.pose.position.y = p[0], p[1]
        msg.pose.orientation.z, msg.pose.orientation.w = math.sin(p[2] / 2), math.cos(p[2] / 2)
        return msg

    plan = make_plan(start=pose(start), goal=pose(goal), tolerance=0.0).plan
    if not plan.poses:
        return None
    xy = np.array([[p.pose.position.x, p.pose.position.y] for p in plan.poses])
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    length = float(along[-1])

    def heading(a, b):  # direction [rad] from a to b
        return math.atan2(b[1] - a[1], b[0] - a[0])

    first = min(int(np.searchsorted(along, 0.3)), len(xy) - 1)  # 0.3 m of plan at each end
    last = max(int(np.searchsorted(along, length - 0.3)) - 1, 0)
    turns = turn_time(heading(xy[0], xy[first]) - start[2]) + turn_time(goal[2] - heading(xy[last], xy[-1]))
    return length, turns


def plot(path, grid, legs, title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 8.5))
    ax.imshow(grid.shades(), cmap="gray", origin="lower", extent=grid.extent, vmin=0, vmax=1)
    for leg in legs:
        track = np.asarray(leg["track"])
        if len(track):
            color = "tab:blue" if leg["state"] == "SUCCEEDED" else "tab:red"
            ax.plot(track[:, 1], track[:, 2], "-", color=color, lw=0.8, alpha=0.6)
        ax.plot(leg["goal"][0], leg["goal"][1], "x", color="tab:orange", ms=4)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


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
        clearance_of(args.clearance_of)
        return

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
        from nav_msgs.srv import GetPlan

        rospy.init_node("bench", anonymous=False, disable_signals=True)
        session = NavSession()
        if not session.wait_ready(180.0):
            raise SystemExit(f"move_base did not come up:\n{stack.output()}")
        wait_for(lambda: session.sim_now() > 3.0, 60, what="the simulation to run")
        time.sleep(1.0)
        # goals come from the map move_base plans on: florence_sim's keep-out map (table tops and
        # chair seats marked), so no goal is under a table
        from map_server.node import msg_to_grid
        from nav_msgs.msg import OccupancyGrid

        grid = msg_to_grid(rospy.wait_for_message("/florence_sim/keepout_map", OccupancyGrid, timeout=60))
        rospy.wait_for_service("/move_base/make_plan", 60)
        make_plan = rospy.ServiceProxy("/move_base/make_plan", GetPlan)
        pid = node_pid(master.uri, "/move_base")

        from florence_sim.world import load_world

        scene = load_world(WORLD).scene
        radius, height = robot_body()
        legs = []
        goals = random_goals(grid, args.pairs * 3, args.clearance, rng)
        cpu0, sim0, wall0 = cpu_seconds(pid), session.sim_now(), time.monotonic()
        for goal in goals:
            if len(legs) >= args.pairs:
                break
            here = session.latest()
            planned = plan_length(make_plan, (here[1], here[2], here[3]), goal)
            if planned is None or planned[0] < 0.5:
                continue  # not reachable from here (a closed-off corner) or no real leg
            ideal, turns = planned
            collisions_before, poses_before = session.collisions, len(session.collision_poses)
            t0 = session.sim_now()
            state, text, took, driven = session.go(*goal, sim_timeout=args.leg_timeout)
            # move_base ends a goal once within its tolerances (TrajectoryPlannerROS); the base may
            # still be braking then. Each leg starts from rest, and the bench says when rest came.
            session.wait_still(sim_time=0.3)
            track = session.track(since=t0)
            rest = time_to_rest(track, t0)
            rest_error = goal_error(track, goal)[0]
            clearance = body_clearance(scene, track, radius, height)  # until rest
            track = track[track[:, 0] <= t0 + took]
            end_error, end_yaw_error = goal_error(track, goal)
            legs.append({
                "goal": [float(v) for v in goal], "state": state, "text": text, "time_s": took,
                "plan_length_m": ideal, "driven_m": driven, "ratio": took / (ideal / MAX_VEL_X),
                "turns_s": turns, "ratio_with_turns": took / (ideal / MAX_VEL_X + turns),
                "rest_s": rest, "ratio_to_rest": rest / (ideal / MAX_VEL_X),
                "end_error_m": end_error, "end_yaw_error_rad": end_yaw_error, "rest_error_m": rest_error,
                **time_breakdown(track), **leg_phases(track, goal),
                "collisions": session.collisions - collisions_before,
                "collision_poses": [list(p) for p in session.collision_poses[poses_before:]],
                "body_clearance_m": clearance,
                "track": track[::5].round(3).tolist(),
            })
            print(f"{len(legs):3d}: {state:9s} {took:6.1f} s plan {ideal:5.2f} m ratio {legs[-1]['ratio']:4.2f} "
                  f"(at rest {rest - took:+.1f} s) {text if state != 'SUCCEEDED' else ''}", flush=True)
        cpu = cpu_seconds(pid) - cpu0
        sim_total, wall_total = session.sim_now() - sim0, time.monotonic() - wall0

        ok = [leg for leg in legs if leg["state"] == "SUCCEEDED"]

        def median(key):  # over the goals reached
            return float(np.median([leg[key] for leg in ok])) if ok else None

        ratios = np.array([leg["ratio"] for leg in ok])
        result = {
            "pairs": len(legs), "succeeded": len(ok), "success_rate": len(ok) / max(1, len(legs)),
            "collisions": int(sum(leg["collisions"] for leg in legs)),
            # each leg's least ground-truth gap between the robot's body and the world, every pose
            "body_clearance_m": clearance_spread([leg["body_clearance_m"] for leg in legs]),
            "time_ratio_median": float(np.median(ratios)) if len(ratios) else None,
            "time_ratio_p90": float(np.percentile(ratios, 90)) if len(ratios) else None,
            "time_ratio_max": float(ratios.max()) if len(ratios) else None,
            # the same against plan length / max_vel_x plus the least time for the turn from the robot's
            # heading onto the plan and from the plan's last heading to the goal yaw (max_rotational_vel,
            # velocity_filter's angular acceleration): what the random goal yaws cost at best
            "time_ratio_with_turns_median": median("ratio_with_turns"),
            # the same to the moment the base is at rest (the goal ends while it may still brake or
            # finish its turn under velocity_filter's deceleration)
            "time_to_rest_ratio_median": median("ratio_to_rest"),
            "rest_after_outcome_s": ({"median": float(np.median([leg["rest_s"] - leg["time_s"] for leg in ok])),
                                      "max": float(max(leg["rest_s"] - leg["time_s"] for leg in ok))} if ok else None),
            # the first 0.5 m and the last 0.8 m of a leg (1.5 s and 2.1 s in a straight line)
            "phases_median_s": {k: median(k) for k in ("start_s", "end_s")},
            # ground truth against the goal at the result and once at rest (move_base judges by amcl's
            # pose; xy_goal_tolerance 0.25 m, yaw_goal_tolerance 0.3 rad)
            "goal_error": {k: error_spread([leg[k] for leg in ok], tol)
                           for k, tol in (("end_error_m", 0.25), ("end_yaw_error_rad", 0.3),
                                          ("rest_error_m", 0.25))},
            "time_share": {k: float(sum(leg[k] for leg in ok) / max(1e-9, sum(leg["time_s"] for leg in ok)))
                           for k in ("driving_s", "turning_in_place_s", "standing_s")},
            "move_base_cpu_fraction": cpu / wall_total, "move_base_cpu_s_per_sim_s": cpu / sim_total,
            "sim_time_s": sim_total, "wall_time_s": wall_total, "rtf": args.rtf, "seed": args.seed,
            "failures": [{k: leg[k] for k in ("goal", "state", "text")} for leg in legs if leg["state"] != "SUCCEEDED"],
            "targets": {"success_rate": 0.98, "collisions": 0, "time_ratio_median": 1.3},
            "load_average_1min": os.getloadavg()[0],
        }
        plot(RESULTS / "nav.png", grid, legs,
             f"move_base: {len(ok)}/{len(legs)} goals, {result['collisions']} collisions, median time/ideal "
             f"{result['time_ratio_median'] or float('nan'):.2f}")
        (RESULTS / "nav.json").write_text(json.dumps({**result, "legs": legs}, indent=1))
        print(json.dumps(result, indent=2))
        print(f"wrote {RESULTS / 'nav.json'} and {RESULTS / 'nav.png'}")
        session.close()
    finally:
        stack.stop()
        master.stop()


if __name__ == "__main__":
    main()
