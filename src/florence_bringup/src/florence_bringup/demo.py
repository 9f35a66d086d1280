"""The main job (`make demo`): run the Florence system headless and write a report.

Today the workspace has its robot description; the simulator and the behaviour
nodes arrive with later issues. So the demo runs what exists for real: a private
rosmaster, turtlebot_control's description.launch (robot_state_publisher and
joint_state_publisher on the xacro model), reads the live tf tree, checks the
frame conventions the other nodes rely on, and writes the report. With a display
(``DISPLAY`` set) it also opens rviz with the shipped configuration.

Usage: python3 -m florence_bringup.demo [--output DIR] [--rviz auto|yes|no] [--timeout S]
"""

import argparse
import datetime
import json
import os
import signal
import sys
import xml.etree.ElementTree as ET

from florence_bringup.tf_report import FrameLink, check_conventions, render_tree
from florence_harness.processes import HarnessError, ManagedProcess, RosMaster, roslaunch, wait_for

ROOT_FRAME = "base_footprint"


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
        return set(links) <= set(known) | {ROOT_FRAME} and known

    known = wait_for(all_known, timeout, what="every link of the robot in tf")
    frames = {}
    for child, info in known.items():
        parent = info["parent"]
        t = buffer.lookup_transform(parent, child, rospy.Time(0)).transform
        frames[child] = FrameLink(
            parent,
            (t.translation.x, t.translation.y, t.translation.z),
            (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w),
        )
    del listener
    return frames


def _write_atomically(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def write_report(out_dir, frames, checks, links, master_uri):
    os.makedirs(out_dir, exist_ok=True)
    tree = render_tree(frames, ROOT_FRAME)
    passed = all(ok for _, ok, _ in checks)
    lines = [
        "# Florence demo report",
        "",
        f"- time: {datetime.datetime.now().isoformat(timespec='seconds')}",
        f"- ROS master: {master_uri} (private, stopped at the end)",
        "- ran: turtlebot_control/description.launch (robot_state_publisher, joint_state_publisher)",
        "- not yet in the workspace: simulator and behaviour nodes (later issues), so no scenario ran",
        f"- robot links in the URDF: {len(links)}; frames in tf: {len(frames) + 1}",
        f"- frame conventions: {'all passed' if passed else 'FAILED'}",
        "",
        "## Frame conventions (live tf)",
        "",
        *[f"- [{'x' if ok else ' '}] {name}: {detail}" for name, ok, detail in checks],
        "",
        "## tf tree",
        "",
        "```",
        tree,
        "```",
        "",
    ]
    report = "\n".join(lines)
    _write_atomically(os.path.join(out_dir, "report.md"), report)
    data = {
        child: {"parent": link.parent, "translation": list(link.translation), "rotation_xyzw": list(link.rotation)}
        for child, link in frames.items()
    }
    _write_atomically(os.path.join(out_dir, "frames.json"),
                      json.dumps({"root": ROOT_FRAME, "frames": data, "checks": checks}, indent=2))
    return report, passed


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", default="demo_output", help="directory for report.md and frames.json")
    parser.add_argument("--rviz", choices=("auto", "yes", "no"), default="auto",
                        help="open rviz (auto: only when DISPLAY is set)")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds to wait for the tf tree")
    args = parser.parse_args(argv)

    # SIGTERM (e.g. from `timeout` or a supervisor) must still stop every child below.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    master = RosMaster().start()
    processes = []
    try:
        os.environ.update({k: v for k, v in master.env().items() if k.startswith("ROS_")})
        print(f"demo: private ROS master at {master.uri}", flush=True)
        processes.append(roslaunch(master, "turtlebot_control", "description.launch"))

        import rospy

        rospy.init_node("florence_demo", disable_signals=True)
        urdf = wait_for(lambda: rospy.get_param("/robot_description", None), args.timeout,
                        what="robot_description on the parameter server")
        links = _links_of(urdf)
        frames = read_tf_tree(rospy, links, args.timeout)
        checks = check_conventions(frames)
        report, passed = write_report(args.output, frames, checks, links, master.uri)
        print(report, flush=True)
        print(f"demo: report written to {os.path.join(os.path.abspath(args.output), 'report.md')}", flush=True)

        if args.rviz == "yes" or (args.rviz == "auto" and os.environ.get("DISPLAY")):
            import rospkg

            config = os.path.join(rospkg.RosPack().get_path("florence_bringup"), "rviz", "florence.rviz")
            rviz = ManagedProcess(["rviz", "-d", config, "-f", ROOT_FRAME], env=master.env(), name="rviz")
            processes.append(rviz)
            print("demo: rviz is open; close its window (or press Ctrl-C) to end the demo", flush=True)
            rviz.proc.wait()
        rospy.signal_shutdown("demo over")
        return 0 if passed else 1
    except HarnessError as exc:
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
    sys.exit(main())
