"""The main job (`make demo`): the whole Florence system in florence_sim, headless, a scripted day
of the Florence services, and a report with pictures.

Starts a private rosmaster and ``roslaunch florence_bringup florence_bringup.launch sim:=true`` (one
launch: florence_sim's apartment, the description, filters, multiplexer and collision monitor, the
Kinect's fake laser, map_server with the keep-out map, amcl, move_base, the user tracker and its
filter, florenceLocator, detect_users, approach_me_map, follow_me, approach_me), reads the live tf
tree and checks the frame conventions, then runs the day of :mod:`florence_scenarios.day` through
the system's public interfaces, judged against the simulator's ground truth, while it measures the
CPU time of every node (:mod:`florence_scenarios.cpu`). Writes ``report.md``, ``report.html``
(self-contained, the pictures inlined), ``day.json`` and ``frames.json`` into ``--output``
(:mod:`florence_scenarios.report`). With a display (``DISPLAY`` set) it opens rviz with
florence_bringup's configuration and runs in real time so it can be watched.

Usage: python3 -m florence_scenarios.demo [--output DIR] [--rviz auto|yes|no] [--timeout S]
                                          [--real-time-factor F] [--seed N] [--steps a,b,...]
Exit status: 0 when every check passed, 1 when one failed, 2 when the demo could not run.
"""

import argparse
import datetime
import os
import shutil
import signal
import sys
import time
import xml.etree.ElementTree as ET

from florence_common.maps import map_file
from florence_common.processes import ManagedProcess, ProcessError, RosMaster, roslaunch, wait_for
from florence_scenarios import day, judge, report
from florence_scenarios.checks import Checks
from florence_scenarios.cpu import CpuMeter
from florence_scenarios.tf_report import FrameLink, check_conventions

DEFAULT_RTF = 2.0  # headless: simulated seconds per wall second


def _links_of(urdf_xml):
    return sorted(link.get("name") for link in ET.fromstring(urdf_xml).iter("link"))


def read_tf_tree(rospy, links, timeout):
    """Wait until tf knows every URDF link, then return ``{child: FrameLink}``."""
    import tf2_ros
    import yaml

    buffer = tf2_ros.Buffer()
    listener = tf2_ros.TransformListener(buffer)

    def all_known():
        known = yaml.safe_load(buffer.all_frames_as_yaml()) or {}
        return set(links) <= set(known) | {report.ROOT_FRAME} and known

    known = wait_for(all_known, timeout, what="every link of the robot in tf")
    frames = {}
    for child, info in known.items():
        t = buffer.lookup_transform(info["parent"], child, rospy.Time(0)).transform
        frames[child] = FrameLink(info["parent"], (t.translation.x, t.translation.y, t.translation.z),
                                  (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w))
    listener.unregister()  # tf at its full rate is not wanted in this process any more
    return frames


def wait_simulator(sim, rospy, timeout):
    """Wait for the simulator's /clock; fail at once (not after a timeout) when it dies at start-up."""
    from rosgraph_msgs.msg import Clock

    def started():
        if not sim.running():
            return "died"
        try:
            rospy.wait_for_message("/clock", Clock, 0.5)
            return "ok"
        except rospy.ROSException:
            return None

    if wait_for(started, timeout, what="the simulator's /clock") == "died":
        raise ProcessError("florence_bringup.launch exited at start-up (see its output above)")


def start_system(args, master, processes, out_dir, show):
    """florence_bringup.launch sim:=true with the day's people, a copy of the hotspots (setHotspot
    writes it) and the robot in the kitchen; returns (the launch, its command line, the hotspots file)."""
    import rospkg

    os.makedirs(out_dir, exist_ok=True)
    hotspots = os.path.join(out_dir, "hotspots.yaml")
    shutil.copy(os.path.join(rospkg.RosPack().get_path("florence_locator"), "config", "hotspots.yaml"), hotspots)
    people = day.people_file(os.path.join(out_dir, "people.yaml"))
    rtf = args.real_time_factor if args.real_time_factor is not None else (1.0 if show else DEFAULT_RTF)
    x, y, yaw = day.START
    launch_args = ["sim:=true", f"real_time_factor:={rtf}", f"x:={x}", f"y:={y}", f"yaw:={yaw:.4f}",
                   f"seed:={args.seed}", f"people:={people}", f"hotspots_file:={hotspots}"]
    stack = roslaunch(master, "florence_bringup", "florence_bringup.launch", *launch_args)
    processes.append(stack)
    return stack, "roslaunch florence_bringup florence_bringup.launch " + " ".join(launch_args), hotspots, rtf


def run(args, master, processes):
    """Everything after the master is up; returns the exit status."""
    show = args.rviz == "yes" or (args.rviz == "auto" and bool(os.environ.get("DISPLAY")))
    wall0 = time.monotonic()
    started = datetime.datetime.now().isoformat(timespec="seconds")
    stack, command, hotspots, rtf = start_system(args, master, processes, args.output, show)
    print(f"demo: {command}", flush=True)

    import rospy

    rospy.init_node("florence_demo", disable_signals=True)
    wait_for(lambda: (rospy.has_param("/florence_sim/world") and rospy.has_param("/robot_description"))
             or not stack.running(), args.timeout, what="florence_bringup.launch started")
    wait_simulator(stack, rospy, args.timeout)
    rviz = None
    if show:
        import rospkg

        config = os.path.join(rospkg.RosPack().get_path("florence_bringup"), "rviz", "florence.rviz")
        rviz = ManagedProcess(["rviz", "-d", config], env=master.env(), name="rviz")
        processes.append(rviz)
        print("demo: rviz is open; the day runs while you watch", flush=True)

    links = _links_of(rospy.get_param("/robot_description"))
    frames = read_tf_tree(rospy, links, args.timeout)
    sections = {"Frame conventions (live tf)": check_conventions(frames)}
    print(f"demo: tf conventions: {'all passed' if sections['Frame conventions (live tf)'].passed else 'FAILED'}",
          flush=True)

    session = day.DaySession()
    try:
        session.wait_ready(args.timeout * 3)
        session.wait_enablers(args.timeout)
        rospy.wait_for_service("/user_tracker_ni_node/Start", args.timeout)
        session.wait_sim(2.0)  # a fresh action client's first goal can be lost while connections settle
        meter = CpuMeter(master.uri, exclude={"/florence_demo", "/cpu_meter"}).start()
        first = meter.sample()
        sim0, day_wall0 = session.sim_now(), time.monotonic()
        the_day = day.Day(session, master, processes, hotspots, meter=meter, timeout=args.timeout,
                          steps=args.steps)
        _, checks = the_day.run()
        last = meter.stop()
        sim1 = session.sim_now()
        cpu, cpu_total = judge.cpu_per_node(first, last, sim1 - sim0)
        record = collect(session, the_day, sim0)
    finally:
        session.set_override(False)
        session.close()
    overall = Checks()
    overall.add("no collision all day (ground truth)", session.collisions == 0, f"{session.collisions} collision(s)")
    kept, worst, row = judge.personal_space_kept(record["least"])
    overall.add("the robot kept 0.45 m from everybody while driving (except the approaches' ends asked of it)",
                kept, f"least {worst:.2f} m ({row['person']} in {row['window']})" if row else "nobody seen")
    sections["The day"] = checks
    sections["All day"] = overall
    sim_s, wall_s = sim1 - sim0, time.monotonic() - day_wall0
    record.update(sections=sections, frames=frames, links=links, cpu=cpu, cpu_total=cpu_total, summary={
        "command": command, "real_time_factor": rtf, "achieved_real_time_factor": sim_s / max(wall_s, 1e-6),
        "sim_seconds": sim_s, "wall_seconds": wall_s, "wall_seconds_with_start_up": time.monotonic() - wall0,
        "started": started})
    from map_server.mapfile import load_map

    text, passed = report.write(args.output, record, load_map(str(map_file("apartment", "apartment.yaml"))))
    robot = report.robot_cpu(cpu, cpu_total)
    print(f"demo: the day took {sim_s:.0f} simulated s in {wall_s:.0f} wall s (real-time factor "
          f"{sim_s / max(wall_s, 1e-6):.2f}); the whole system {cpu_total:.2f} cores at real time"
          + (f", {robot:.2f} without the simulator" if robot is not None else ""), flush=True)
    for heading, group in sections.items():
        print(f"demo: {heading}: {'all passed' if group.passed else 'FAILED: ' + '; '.join(group.failed())}",
              flush=True)
    shutil.copyfile(stack.log_path, os.path.join(args.output, "stack.log"))
    print(f"demo: report written to {os.path.join(os.path.abspath(args.output), 'report.md')} (and report.html; "
          "what the nodes printed in stack.log)", flush=True)
    del text
    if rviz is not None:
        print("demo: rviz is open; close its window (or press Ctrl-C) to end the demo", flush=True)
        rviz.proc.wait()
    rospy.signal_shutdown("demo over")
    return 0 if passed else 1


def collect(session, the_day, since):
    """The day's record for the report from the session's recorders (ground truth, amcl, people)."""
    track = session.track(since)
    people_log = session.people_log(since)
    amcl = session.amcl_log()
    amcl = amcl[amcl[:, 0] >= since] if len(amcl) else amcl
    people = {}
    for _, where in people_log[::5]:
        for pid, p in where.items():
            people.setdefault(pid, []).append((round(p[0], 3), round(p[1], 3)))
    windows = [(st.name, st.data.get("judged_from", st.start), st.end) for st in the_day.steps]
    excused = {("gotoUser", day.USER), ("approach_me", day.USER)}
    least = judge.least_distances(track, people_log, windows, excused)
    for row in least:
        row["at_s"] -= the_day.t0  # the day's time, as the steps and calls give it
    marks = [(float(p[0][0]), float(p[0][1]), f"{pid} at the start") for pid, p in people.items() if p]
    for st in the_day.steps:
        rows = track[track[:, 0] <= st.end]
        if len(rows) and st.name not in ("setUserPosRoom", "bad input"):
            marks.append((float(rows[-1, 1]), float(rows[-1, 2]), st.name))
    return {"steps": [st.as_json() for st in the_day.steps], "calls": the_day.calls,
            "robot_truth": track[::5, 1:3].round(3).tolist(), "robot_amcl": amcl[:, 1:3].round(3).tolist(),
            "people": people, "marks": marks, "follow": the_day.follow, "least": least}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", default="demo_output",
                        help="directory for report.md, report.html, day.json, frames.json and the pictures")
    parser.add_argument("--rviz", choices=("auto", "yes", "no"), default="auto",
                        help="open rviz (auto: only when DISPLAY is set)")
    parser.add_argument("--timeout", type=float, default=60.0,
                        help="wall seconds to wait for each start-up condition (the steps wait in simulated time)")
    parser.add_argument("--seed", type=int, default=3, help="florence_sim's random seed (sensor and odometry noise)")
    parser.add_argument("--steps", default="all",
                        help=f"the day's steps to run, comma-separated, in the day's order ({','.join(day.STEPS)}; "
                             "default all)")
    parser.add_argument("--real-time-factor", type=float, default=None,
                        help=f"simulation speed (default: 1 with rviz, {DEFAULT_RTF:g} headless)")
    args = parser.parse_args(argv)
    chosen = [] if args.steps == "all" else [name.strip() for name in args.steps.split(",") if name.strip()]
    unknown = [name for name in chosen if name not in day.STEPS]
    if unknown:
        parser.error(f"unknown steps {unknown}: the day's steps are {','.join(day.STEPS)}")

    # SIGTERM (e.g. from `timeout` or a supervisor) must still stop every child below.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    master = RosMaster().start()
    processes = []
    try:
        os.environ.update({k: v for k, v in master.env().items() if k.startswith("ROS_")})
        print(f"demo: private ROS master at {master.uri}", flush=True)
        return run(args, master, processes)
    except ProcessError as exc:
        for proc in processes:
            print(f"----- {proc.name} -----\n{proc.output()}", file=sys.stderr)
        print(f"demo: FAILED: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except Exception as exc:  # noqa: BLE001 - any other failure to run: said, with what the system printed
        import traceback

        traceback.print_exc()
        for proc in processes:
            print(f"----- {proc.name} (tail) -----\n{proc.output(6000)}", file=sys.stderr)
        print(f"demo: FAILED: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 2
    finally:
        for proc in reversed(processes):
            proc.stop()
        master.stop()


if __name__ == "__main__":
    try:
        code = main()
    except SystemExit as exc:  # SIGTERM's handler, after main's finally stopped every child
        code = exc.code if isinstance(exc.code, int) else 1
    sys.stdout.flush()
    sys.stderr.flush()
    # Every child is stopped by now. Once in the test suite a demo stopped by SIGTERM did not end within
    # 60 s (cause not found; a non-daemon thread would keep the interpreter at exit): end here.
    os._exit(code)
