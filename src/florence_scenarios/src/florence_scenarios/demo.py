"""The main job (`make demo`): the Florence robot in the simulator, headless, and a report.

Starts a private rosmaster and the navigation stack in simulation
(``turtlebot_2dnav_control.launch sim:=true``: florence_sim's apartment with two walking
people, robot_state_publisher, the Florence filters and velocity multiplexer, map_server,
amcl, move_base), reads the live tf tree and checks the frame conventions the other nodes
rely on, then runs the two scenarios of :mod:`florence_scenarios.scenarios` and writes the
report (:mod:`florence_scenarios.report`). With a display (``DISPLAY`` set) it opens rviz
with the simulator's configuration first and runs in real time so it can be watched.

Usage: python3 -m florence_scenarios.demo [--output DIR] [--rviz auto|yes|no] [--timeout S]
                                          [--real-time-factor F]
Exit status: 0 when every check passed, 1 when one failed, 2 when the demo could not run.
"""

import argparse
import os
import signal
import sys
import xml.etree.ElementTree as ET

from florence_common.processes import ManagedProcess, ProcessError, RosMaster, roslaunch, wait_for
from florence_scenarios import report, scenarios
from florence_scenarios.observer import Observer
from florence_scenarios.tf_report import FrameLink, check_conventions


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
    del listener
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
        raise ProcessError("turtlebot_2dnav_control.launch exited at start-up (see its output above)")


def run(args, master, processes):
    """Everything after the master is up; returns the exit status."""
    show = args.rviz == "yes" or (args.rviz == "auto" and bool(os.environ.get("DISPLAY")))
    rtf = args.real_time_factor if args.real_time_factor is not None else (1.0 if show else 3.0)
    x, y, yaw = scenarios.START
    stack = roslaunch(master, "turtlebot_control", "turtlebot_2dnav_control.launch", "sim:=true",
                      f"real_time_factor:={rtf}", f"x:={x}", f"y:={y}", f"yaw:={yaw}")
    processes.append(stack)

    import rospy

    rospy.init_node("florence_demo", disable_signals=True)
    wait_for(lambda: (rospy.has_param("/florence_sim/world") and rospy.has_param("/robot_description"))
             or not stack.running(), args.timeout, what="florence_sim.launch started")
    wait_simulator(stack, rospy, args.timeout)
    rviz = None
    if show:
        import rospkg

        config = os.path.join(rospkg.RosPack().get_path("florence_sim"), "rviz", "florence_sim.rviz")
        rviz = ManagedProcess(["rviz", "-d", config], env=master.env(), name="rviz")
        processes.append(rviz)
        print("demo: rviz is open; the scenario runs while you watch", flush=True)

    links = _links_of(rospy.get_param("/robot_description"))
    frames = read_tf_tree(rospy, links, args.timeout)
    sections = {"Frame conventions (live tf)": check_conventions(frames)}
    obs = Observer(rospy)
    steps, summary = scenarios.by_hand(rospy, obs, args.timeout)
    obs.close()
    sections["Scenario checks"] = scenarios.by_hand_checks(steps, summary)
    goals, sections["Navigation checks"] = scenarios.navigation(rospy, args.timeout)
    text, passed = report.write(args.output, master.uri, frames, links, sections, steps, summary, goals)
    print(text, flush=True)
    print(f"demo: report written to {os.path.join(os.path.abspath(args.output), 'report.md')}", flush=True)
    if rviz is not None:
        print("demo: rviz is open; close its window (or press Ctrl-C) to end the demo", flush=True)
        rviz.proc.wait()
    rospy.signal_shutdown("demo over")
    return 0 if passed else 1


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", default="demo_output", help="directory for report.md, frames.json, scenario.json")
    parser.add_argument("--rviz", choices=("auto", "yes", "no"), default="auto",
                        help="open rviz (auto: only when DISPLAY is set)")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds to wait for each step")
    parser.add_argument("--real-time-factor", type=float, default=None,
                        help="simulation speed (default: 1 with rviz, 3 headless)")
    args = parser.parse_args(argv)

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
