"""amcl's benchmark runs (bench/amcl.py is their command line): the update time of the core on the
apartment map, the offline tracking and global-localization runs, and the same on ROS with
florence_sim, map_server and the shipped amcl launch file on a private master."""

import math
import os
import time
from pathlib import Path

import numpy as np

from florence_common.maps import map_file
from florence_eval.metrics import memory_kib, node_pid

MAP_YAML = map_file("apartment", "apartment.yaml")


def update_time(updates=400, particles=500, beams=60, seed=3):
    """Update time of the core with a fixed particle count on the apartment map (ms per update)."""
    from amcl.localizer import AmclConfig, Localizer
    from amcl.particle_filter import FilterParams
    from amcl.sensor import LaserParams, beams_in_base
    from map_server.mapfile import load_map

    grid = load_map(str(MAP_YAML))
    config = AmclConfig(filter=FilterParams(min_particles=particles, max_particles=particles, kld_err=0.05,
                                            resample_interval=1),
                        laser=LaserParams(z_hit=0.5, z_rand=0.5, sigma_hit=0.1, interpolate=True),
                        laser_max_beams=beams,
                        odom_alphas=(0.2, 0.2, 0.2, 0.2, 0.2), update_min_d=0.0, update_min_a=0.0)
    rng = np.random.default_rng(seed)
    loc = Localizer(config, rng)
    loc.set_map(grid.data, grid.resolution, grid.origin[:2])
    angles = np.linspace(-1.570, 1.570, 513)
    laser_xy, bearings = beams_in_base((0.06, 0.0, -0.02), (1.0, 0.0, 0.0, 0.0), angles)
    pose = np.array([1.0, 2.5, 0.0])
    loc.set_pose(pose, np.diag([0.01, 0.01, 0.005]))
    times, cpu = [], []
    for i in range(updates):
        pose = pose + np.array([0.02 * math.cos(pose[2]), 0.02 * math.sin(pose[2]), 0.01 * math.sin(i / 20)])
        c, s = math.cos(pose[2]), math.sin(pose[2])
        lx, ly = np.full(angles.shape, pose[0] + c * 0.06), np.full(angles.shape, pose[1] + s * 0.06)
        ranges = loc.map.calc_range(lx, ly, pose[2] + bearings, 5.6) + rng.normal(0, 0.01, angles.shape)
        start_cpu = time.thread_time()
        start = time.perf_counter()
        loc.process_scan(pose, laser_xy, bearings, ranges, 0.02, 5.6)
        times.append((time.perf_counter() - start) * 1000.0)
        cpu.append((time.thread_time() - start_cpu) * 1000.0)
    used = len(np.arange(0, 513, max(1, 512 // (beams - 1))))
    return {"particles": particles, "beams_used": used, "updates": updates,
            "p50_ms": float(np.percentile(times, 50)), "p99_ms": float(np.percentile(times, 99)),
            "max_ms": float(np.max(times)), "cpu_p50_ms": float(np.percentile(cpu, 50)),
            "cpu_p99_ms": float(np.percentile(cpu, 99)), "load_average_1min": os.getloadavg()[0],
            "note": "wall-clock p99 includes waiting for a CPU on a loaded machine; cpu_* is this thread's CPU time"}


def plot_tour(path, grid, truth, est, title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 8.5))
    ax.imshow(grid.shades(), cmap="gray", origin="lower", extent=grid.extent, vmin=0, vmax=1)
    ax.plot(truth[:, 0], truth[:, 1], "-", color="tab:green", lw=1.5, label="ground truth")
    ax.plot(est[:, 0], est[:, 1], ".", color="tab:red", ms=3, label="amcl_pose")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title, fontsize=9)
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def offline(seeds, length, global_seeds, global_max, command):
    """Tracking and global localization in-process (florence_eval.amcl_offline); returns the result dict."""
    from florence_eval.amcl_offline import global_starts, launch_params, run_global, run_tracking

    params = launch_params()
    tracking = {}
    for seed in seeds:
        tracking[seed] = run_tracking(params, length=length, sim_seed=seed, amcl_seed=seed).tracking_summary()
        print(f"tracking seed {seed}: {tracking[seed]}", flush=True)
    trials = []
    for seed in global_seeds:
        for i, start in enumerate(global_starts()):
            run, at = run_global(params, i, sim_seed=seed, amcl_seed=seed + 100, max_drive=global_max)
            trials.append({"seed": seed, "start_pose": [round(v, 2) for v in start], "distance_to_converge_m": at,
                           "driven_m": run.travelled[-1] if run.travelled else 0.0})
            print(f"global seed {seed} start {i}: {trials[-1]}", flush=True)
    within = [t for t in trials if t["distance_to_converge_m"] is not None and t["distance_to_converge_m"] <= 10.0]
    print(f"global localization: converged within 10 m in {len(within)}/{len(trials)}", flush=True)
    micro = update_time()
    print(f"update time, 500 particles, 60 beams: {micro}", flush=True)
    return {"command": command, "tracking": tracking,
            "global_localization": {"trials": trials, "converged_within_10_m": f"{len(within)}/{len(trials)}"},
            "update_time_500_particles_60_beams": micro,
            "note": "offline: florence_sim core + amcl core in one process, apartment without people, "
                    "amcl_turtlebot_control.launch values; errors after convergence (0.1 m / 5 deg)"}


def ros_run(length, rtf, seed, with_people, global_max, global_trials, results_dir, command):
    """Tracking and global localization with the nodes on a private master; writes amcl.png into
    ``results_dir`` and returns the result dict."""
    from florence_common.processes import ManagedProcess, RosMaster, roslaunch, wait_for

    master = RosMaster().start()
    os.environ.update({k: v for k, v in master.env().items() if k.startswith("ROS_")})
    procs = []
    try:
        from florence_eval.tour import APARTMENT_LOOP, APARTMENT_START, tour
        x, y, yaw = APARTMENT_START
        people = map_file("apartment", "people.yaml")
        if not with_people:
            people = Path(master.ros_home) / "nobody.yaml"
            people.write_text("people: []\n")
        procs.append(roslaunch(master, "florence_sim", "florence_sim.launch", f"people:={people}",
                               f"real_time_factor:={rtf}", f"seed:={seed}", f"x:={x}", f"y:={y}",
                               f"yaw:={yaw}"))
        import rosgraph
        import rospy
        from geometry_msgs.msg import PoseWithCovarianceStamped
        from std_srvs.srv import Empty

        from florence_common_ros.convert import pose_msg

        # One roslaunch at a time: two starting together race for the master's run_id.
        wait_for(lambda: rosgraph.Master("/bench").hasParam("/run_id"), 60, what="florence_sim's roslaunch")
        procs.append(ManagedProcess(["rosrun", "map_server", "map_server", str(MAP_YAML)], env=master.env(),
                                    name="map_server"))
        procs.append(roslaunch(master, "turtlebot_control", "amcl_turtlebot_control.launch",
                               f"initial_pose_x:={x}", f"initial_pose_y:={y}", f"initial_pose_a:={yaw}"))
        rospy.init_node("bench", anonymous=False, disable_signals=True)
        from florence_eval.amcl_recorder import TourRecorder

        rec = TourRecorder()
        initial_pub = rospy.Publisher("initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
        wait_for(lambda: rec.latest_truth() is not None, 120, what="ground truth from florence_sim")
        wait_for(lambda: len(rec.snapshot()[2]) > 0, 120, what="the first amcl_pose")
        pid = node_pid(master.uri, "/amcl")

        # 1. tracking
        waypoints = tour(APARTMENT_START[:2], APARTMENT_LOOP, length)
        wall0, sim0 = time.monotonic(), rospy.Time.now().to_sec()
        complete = rec.drive(waypoints, timeout=length / 0.3 * 3 + 120)
        wall_track, sim_track = time.monotonic() - wall0, rospy.Time.now().to_sec() - sim0
        rospy.sleep(1.0)
        truth_t, truth, est_t, est, node_durations = rec.snapshot()
        memory = memory_kib(pid)

        from florence_eval.tour import convergence_index, estimate_errors, rms, travelled
        pos_err, yaw_err = estimate_errors(est_t, est, truth_t, truth)
        start_idx = convergence_index(pos_err, yaw_err, 0.1, math.radians(5.0)) or 0
        dist = travelled(truth)
        tracking = {
            "tour_length_m": float(dist[-1]), "tour_complete": bool(complete), "estimates": len(est),
            "sim_time_s": sim_track, "wall_time_s": wall_track, "skipped_until_converged": int(start_idx),
            "position_rms_m": rms(pos_err[start_idx:]), "position_max_m": float(np.nanmax(pos_err[start_idx:])),
            "yaw_rms_deg": math.degrees(rms(yaw_err[start_idx:])),
            "yaw_max_deg": math.degrees(float(np.nanmax(yaw_err[start_idx:]))),
            "node_update_p50_ms": float(np.percentile(node_durations, 50) * 1000) if len(node_durations) else None,
            "node_update_p99_ms": float(np.percentile(node_durations, 99) * 1000) if len(node_durations) else None,
        }
        from map_server.mapfile import load_map
        grid = load_map(str(MAP_YAML))
        plot_tour(Path(results_dir) / "amcl.png", grid, truth, est,
             f"amcl tracking: {tracking['tour_length_m']:.1f} m, position RMS "
             f"{tracking['position_rms_m'] * 100:.1f} cm, yaw RMS {tracking['yaw_rms_deg']:.2f} deg")

        # 2. global localization, several trials, each from where the previous drive stopped
        trials = []
        loop_pos = 0  # next waypoint of APARTMENT_LOOP
        for _ in range(global_trials):
            gl_start = rospy.Time.now().to_sec()
            truth_before = len(rec.snapshot()[0])
            rospy.wait_for_service("global_localization", timeout=30)
            rospy.ServiceProxy("global_localization", Empty)()
            rospy.ServiceProxy("request_nomotion_update", Empty)()

            def converged(since=gl_start):
                t_t, t_p, e_t, e_p, _ = rec.snapshot()
                sel = e_t >= since
                if sel.sum() < 5:
                    return False
                pe, ye = estimate_errors(e_t[sel], e_p[sel], t_t, t_p)
                idx = convergence_index(pe, ye)
                return idx is not None and len(pe) - idx >= 8

            loop = APARTMENT_LOOP[loop_pos:] + APARTMENT_LOOP[:loop_pos]
            gl_tour = tour(loop[0], loop, global_max)
            rec.drive(gl_tour, timeout=global_max / 0.3 * 3 + 60, stop_when=converged)
            loop_pos = (loop_pos + rec.reached) % len(APARTMENT_LOOP)
            truth_t, truth, est_t, est, _ = rec.snapshot()
            sel = est_t >= gl_start
            pe, ye = estimate_errors(est_t[sel], est[sel], truth_t, truth)
            idx = convergence_index(pe, ye)
            gl_truth_t, gl_truth = truth_t[truth_before:], truth[truth_before:]
            gl_dist = travelled(gl_truth)
            at = float(np.interp(est_t[sel][idx], gl_truth_t, gl_dist)) if idx is not None else None
            start_pose = gl_truth[0].round(2).tolist() if len(gl_truth) else None
            trials.append({"start_pose": start_pose, "converged": idx is not None, "distance_to_converge_m": at,
                           "driven_m": float(gl_dist[-1]) if len(gl_dist) else 0.0})
            # Back to tracking for the next trial: the true pose as initialpose.
            here = rec.latest_truth()
            msg = PoseWithCovarianceStamped()
            msg.header.frame_id = "map"
            msg.pose.pose = pose_msg(*here[:3])
            msg.pose.covariance[0] = msg.pose.covariance[7] = 0.01
            msg.pose.covariance[35] = 0.01
            initial_pub.publish(msg)
            rospy.sleep(0.5)
        within = [t["distance_to_converge_m"] for t in trials if t["converged"]]
        global_result = {"trials": trials, "converged": f"{len(within)}/{len(trials)}",
                         "converged_within_10_m": f"{sum(d <= 10.0 for d in within)}/{len(trials)}",
                         "median_distance_to_converge_m": float(np.median(within)) if within else None,
                         "max_drive_m": global_max,
                         "criterion": "5 consecutive estimates within 0.2 m and 10 deg"}

        # 3. update time of the core
        micro = update_time()
        memory_end = memory_kib(pid)
        result = {
            "command": command,
            "setup": {"world": "apartment, " + ("2 walking people" if with_people else "no people"),
                      "real_time_factor": rtf, "seed": seed, "speed_mps": 0.3,
                      "amcl_launch": "turtlebot_control/config/amcl_turtlebot_control.launch"},
            "tracking": tracking,
            "targets": {"position_rms_m": 0.05, "yaw_rms_deg": 2.0, "global_within_m": 10.0, "update_p99_ms": 20.0},
            "global_localization": global_result,
            "update_time_500_particles_60_beams": micro,
            "memory_kib": {"after_tour": memory, "end": memory_end},
        }
        result["targets_met"] = {
            "position_rms": tracking["position_rms_m"] <= 0.05,
            "yaw_rms": tracking["yaw_rms_deg"] <= 2.0,
            "global_localization": all(t["converged"] and t["distance_to_converge_m"] <= 10.0 for t in trials),
            "update_p99": micro["p99_ms"] <= 20.0,
            "update_p99_cpu_time": micro["cpu_p99_ms"] <= 20.0,
        }
        return result
    finally:
        for proc in reversed(procs):
            proc.stop()
        master.stop()


