"""Benchmark of florence_sim: CPU seconds per simulated second, real-time factor achieved
unthrottled, and per-sensor render times.

Run after `source devel/setup.bash`:  /usr/bin/python3 bench/sim.py [--seconds 20] [--no-ros]
Writes bench/results/sim.json.

Scenario (issue 3): the apartment, one robot driving, two walking people, laser at
10 Hz, Kinect depth 160x120 at 15 Hz, physics step 10 ms.
- core: the ROS-free simulation loop (people, base, sensor rendering), one thread;
- ros: the florence_sim node unthrottled (real_time_factor 0), publishing every topic,
  with and without a subscriber on the depth image (the node renders a camera only when
  somebody listens); its CPU time is read from /proc.
"""

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from florence_common.files import atomic_write

RESULTS = Path(__file__).resolve().parent / "results"


def make_sim(width=160, height=120):
    from florence_sim.sensors import CameraConfig
    from florence_sim.sim import SimConfig, Simulator

    from florence_common.maps import map_file

    return Simulator.from_files(map_file("apartment", "apartment.world.yaml"), map_file("apartment", "people.yaml"),
                                config=SimConfig(camera=CameraConfig(width=width, height=height)),
                                start=(1.0, 2.5, 0.0))


def run_core(seconds, camera=True):
    """Step the core for ``seconds`` of sim time; the robot drives a slow circle."""
    sim = make_sim()
    steps = round(seconds / sim.cfg.dt)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        sim.base.command(0.2, 0.3, sim.time)
        due = sim.step()
        if "laser" in due:
            sim.scan()
        if camera and "camera" in due:
            sim.render_camera(color=False)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    return {"sim_seconds": seconds, "wall_seconds": wall, "cpu_seconds": cpu,
            "cpu_seconds_per_sim_second": cpu / seconds, "real_time_factor": seconds / wall}


def render_times(repeats=30):
    """Mean CPU time [ms] per render of each sensor (and per physics step), from a few poses
    around the apartment; CPU rather than wall time so that a loaded machine does not count."""
    out = {}
    poses = [(1.0, 2.5, 0.0), (3.0, 6.15, math.pi), (6.3, 2.5, 1.0), (2.0, 7.6, -0.5), (6.5, 7.7, 2.0)]
    for name, (w, h) in {"depth_160x120": (160, 120), "depth_640x480": (640, 480)}.items():
        sim = make_sim(w, h)
        reps = repeats if w <= 160 else max(3, repeats // 6)
        t = []
        for i in range(reps):
            sim.base.set_pose(*poses[i % len(poses)])
            t0 = time.perf_counter()
            sim.render_camera(color=False)
            t.append(time.perf_counter() - t0)
        out[name] = 1e3 * float(np.mean(t))
    sim = make_sim()
    t = []
    for i in range(repeats * 3):
        sim.base.set_pose(*poses[i % len(poses)])
        t0 = time.process_time()
        sim.scan()
        t.append(time.process_time() - t0)
    out["laser_513_beams"] = 1e3 * float(np.mean(t))
    t = []
    for _ in range(repeats * 10):
        t0 = time.process_time()
        sim.step()
        t.append(time.process_time() - t0)
    out["physics_step"] = 1e3 * float(np.mean(t))
    return out


def run_ros(seconds):
    """The node unthrottled, without and then with a depth subscriber."""
    from florence_eval.metrics import cpu_seconds, node_pid

    from florence_common.processes import RosMaster, roslaunch, wait_for

    master = RosMaster().start()
    os.environ.update({k: v for k, v in master.env().items() if k.startswith("ROS_")})
    results = {}
    launch = roslaunch(master, "florence_sim", "florence_sim.launch", "real_time_factor:=0")
    try:
        import rospy
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import Image

        rospy.init_node("bench_sim", disable_signals=True)
        clock = {"t": None}
        rospy.Subscriber("/clock", Clock, lambda m: clock.__setitem__("t", m.clock.to_sec()), queue_size=1)
        wait_for(lambda: clock["t"] is not None and clock["t"] > 1.0, 120.0, what="/clock")
        pid = node_pid(master.uri, "/florence_sim")  # registered: it publishes /clock
        frames = {"n": 0}

        def count(_msg):
            frames["n"] += 1

        for label in ("no_camera_subscriber", "depth_subscriber"):
            sub = None
            if label == "depth_subscriber":
                sub = rospy.Subscriber("/camera/depth/image", Image, count, queue_size=5)
                wait_for(lambda: frames["n"] > 0, 60.0, what="depth images")
            s0, w0, c0, f0 = clock["t"], time.monotonic(), cpu_seconds(pid), frames["n"]
            time.sleep(seconds)
            sim_s, wall_s, cpu_s = clock["t"] - s0, time.monotonic() - w0, cpu_seconds(pid) - c0
            results[label] = {"sim_seconds": sim_s, "wall_seconds": wall_s, "cpu_seconds": cpu_s,
                              "cpu_seconds_per_sim_second": cpu_s / sim_s, "real_time_factor": sim_s / wall_s,
                              "depth_images_per_sim_second": (frames["n"] - f0) / sim_s}
            if sub is not None:
                sub.unregister()
        rospy.signal_shutdown("bench over")
    finally:
        launch.stop()
        master.stop()
    return results


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds of the core runs")
    parser.add_argument("--ros-seconds", type=float, default=10.0, help="wall seconds per ROS measurement")
    parser.add_argument("--no-ros", action="store_true", help="skip the ROS node measurement")
    args = parser.parse_args(argv)
    results = {
        "scenario": "apartment, 1 robot, 2 walking people, laser 10 Hz, depth 160x120 15 Hz, dt 10 ms",
        "core_with_depth": run_core(args.seconds, camera=True),
        "core_without_camera": run_core(args.seconds, camera=False),
        "render_ms": render_times(),
    }
    if not args.no_ros:
        results["ros_node"] = run_ros(args.ros_seconds)
    results["meets_10x_on_one_core"] = results["core_with_depth"]["cpu_seconds_per_sim_second"] <= 0.1
    print(json.dumps(results, indent=2))
    RESULTS.mkdir(parents=True, exist_ok=True)
    atomic_write(str(RESULTS / "sim.json"), json.dumps(results, indent=2).encode())
    print(f"wrote {RESULTS / 'sim.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
