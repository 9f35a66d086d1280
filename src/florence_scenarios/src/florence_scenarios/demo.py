"""The main job (`make demo`): run the Florence robot in the simulator headless and write a report.

The demo starts a private rosmaster and the navigation stack in simulation
(``turtlebot_2dnav_control.launch sim:=true``: florence_sim's apartment with two walking
people, robot_state_publisher, the Florence filters and velocity multiplexer, map_server,
amcl, move_base), reads the live tf tree and checks the frame conventions the other nodes
rely on, then runs two scenarios:

1. by hand, as a person at the keyboard (the multiplexer's teleop input): drive out of the
   living room into the corridor, turn, drive along it, tilt the Kinect, bump into the
   corridor wall and back off; it measures every sensor's rate in simulated time, the
   odometry drift against ground truth and the collisions;
2. by move_base goals, as a client of the navigation stack would: the people leave, and the
   robot goes to the kitchen, the bedroom and back to the living room (room hotspots of
   maps/apartment/rooms.yaml), each goal's outcome, time and final error measured against
   ground truth.

It writes ``report.md``, ``frames.json`` and ``scenario.json``. With a display
(``DISPLAY`` set) it opens rviz with the simulator's configuration first and runs in real
time so it can be watched.

Usage: python3 -m florence_scenarios.demo [--output DIR] [--rviz auto|yes|no] [--timeout S]
                                        [--real-time-factor F]
"""

import argparse
import datetime
import json
import math
import os
import signal
import sys
import threading
import time
import xml.etree.ElementTree as ET

from map_server.mapfile import atomic_write

from florence_scenarios.tf_report import FrameLink, check_conventions, render_tree
from florence_common.processes import ManagedProcess, ProcessError, RosMaster, roslaunch, wait_for

ROOT_FRAME = "base_footprint"
TELEOP = "/cmd_vel_mux/input/teleop"
NAV_GOALS = ("kitchen", "bedroom", "living_room")  # room hotspots the navigation scenario visits
START = (2.45, 4.5, math.pi / 2)  # [m, m, rad] living room, facing its door to the corridor
# topic -> (message module, class) whose rate the report gives
RATES = {
    "/clock": ("rosgraph_msgs.msg", "Clock"),
    "/odom": ("nav_msgs.msg", "Odometry"),
    "/imu/data": ("sensor_msgs.msg", "Imu"),
    "/scan": ("sensor_msgs.msg", "LaserScan"),
    "/camera/depth/image": ("sensor_msgs.msg", "Image"),
    "/camera/rgb/points": ("sensor_msgs.msg", "PointCloud2"),
    "/turtlebot_node/sensor_state": ("turtlebot_node.msg", "TurtlebotSensorState"),
    "/cur_tilt_angle": ("std_msgs.msg", "Float64"),
    "/base_pose_ground_truth": ("nav_msgs.msg", "Odometry"),
    "/people_ground_truth": ("florence_sim.msg", "People"),
    "/diagnostics": ("diagnostic_msgs.msg", "DiagnosticArray"),
}


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


def _yaw(q):
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def _wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


class Observer:
    """Counts the messages of every topic of ``RATES`` and keeps the latest message of the
    topics the scenario reads; the others (images, clouds) are counted undeserialised.
    (rospy shares one connection per topic and process, so each topic gets one subscriber.)"""

    CONTENT = ("/clock", "/odom", "/base_pose_ground_truth", "/turtlebot_node/sensor_state", "/cur_tilt_angle",
               "/people_ground_truth")

    def __init__(self, rospy):
        import importlib

        self.lock = threading.Lock()
        self.latest, self.count = {}, dict.fromkeys(RATES, 0)
        self.subs = []
        for topic, (module, name) in RATES.items():
            cls = getattr(importlib.import_module(module), name) if topic in self.CONTENT else rospy.AnyMsg
            self.subs.append(rospy.Subscriber(topic, cls, self._callback(topic), queue_size=100))

    def _callback(self, topic):
        def cb(msg):
            with self.lock:
                self.latest[topic] = msg
                self.count[topic] += 1

        return cb

    def get(self, topic):
        with self.lock:
            return self.latest.get(topic)

    def counts(self):
        with self.lock:
            return dict(self.count)

    def now(self):
        clock = self.get("/clock")
        return clock.clock.to_sec() if clock else 0.0

    def odom(self):
        """(x, y, yaw) of the odometry in its own frame."""
        p = self.get("/odom").pose.pose
        return p.position.x, p.position.y, _yaw(p.orientation)

    def truth(self):
        p = self.get("/base_pose_ground_truth").pose.pose
        return p.position.x, p.position.y, _yaw(p.orientation)

    def close(self):
        for sub in self.subs:
            sub.unregister()


class Driver:
    """Closed-loop moves on odometry, published on the teleop input at 20 Hz (wall time)."""

    def __init__(self, rospy, observer, timeout):
        from geometry_msgs.msg import Twist

        self.obs = observer
        self.timeout = timeout
        # the multiplexer's teleop input, as turtlebot_teleop would: above move_base, through velocity_filter
        self.pub = rospy.Publisher(TELEOP, Twist, queue_size=1)
        self.Twist = Twist
        wait_for(lambda: self.pub.get_num_connections() > 0, timeout, what="cmd_vel_mux on its teleop input")

    def _run(self, command, done, sim_limit):
        """Publish ``command()`` -> (v, w) until ``done()``; then stop."""
        start, deadline = self.obs.now(), time.monotonic() + self.timeout
        cmd = self.Twist()
        while not done() and self.obs.now() - start < sim_limit:
            if time.monotonic() > deadline:
                raise ProcessError(f"a move did not finish in {self.timeout:.0f} s")
            cmd.linear.x, cmd.angular.z = command()
            self.pub.publish(cmd)
            time.sleep(0.05)
        self.stop()

    def stop(self):
        self.pub.publish(self.Twist())
        start = self.obs.now()
        wait_for(lambda: self.obs.now() > start + 0.3, self.timeout, what="the robot to stop")

    def straight(self, distance, speed=0.3, until=None):
        """Drive ``distance`` [m] by odometry (negative: backwards), slowing down near the end."""
        x0, y0, _ = self.obs.odom()

        def remaining():
            x, y, _ = self.obs.odom()
            return abs(distance) - math.hypot(x - x0, y - y0)

        def command():
            return math.copysign(min(speed, max(0.05, remaining())), distance), 0.0

        self._run(command, lambda: remaining() <= 0.005 or (until is not None and until()),
                  sim_limit=abs(distance) / 0.05 + 5.0)

    def turn(self, angle, rate=0.8):
        """Turn ``angle`` [rad] by the gyro's odometry heading, slowing down near the end."""
        yaw0 = self.obs.odom()[2]

        def remaining():
            return abs(angle) - abs(_wrap(self.obs.odom()[2] - yaw0))

        def command():
            return 0.0, math.copysign(min(rate, max(0.1, 1.5 * remaining())), angle)

        self._run(command, lambda: remaining() <= math.radians(0.5), sim_limit=abs(angle) / 0.1 + 5.0)


def odom_drift(start, odom, truth):
    """Position [m] and heading [rad] error of the odometry, carried into the map frame through
    the start pose (odometry starts at zero where the robot starts)."""
    x0, y0, yaw0 = start
    c, s = math.cos(yaw0), math.sin(yaw0)
    ox, oy, oyaw = odom
    mx, my = x0 + c * ox - s * oy, y0 + s * ox + c * oy
    return math.hypot(mx - truth[0], my - truth[1]), abs(_wrap(yaw0 + oyaw - truth[2]))


def run_scenario(rospy, obs, timeout):
    """The scripted drive; returns the rows of the report's scenario table and the summary."""
    from std_msgs.msg import Float64

    driver = Driver(rospy, obs, timeout)
    wait_for(lambda: all(obs.get(t) for t in Observer.CONTENT), timeout, what="the simulator's topics")
    rows = []
    t0, wall0, counts0 = obs.now(), time.monotonic(), obs.counts()

    def record(step):
        truth, odom = obs.truth(), obs.odom()
        dist, ang = odom_drift(START, odom, truth)
        state = obs.get("/turtlebot_node/sensor_state")
        rows.append({"step": step, "sim_time_s": round(obs.now() - t0, 2),
                     "truth": [round(v, 3) for v in truth], "odom": [round(v, 3) for v in odom],
                     "drift_m": round(dist, 3), "drift_deg": round(math.degrees(ang), 2),
                     "bumps_wheeldrops": state.bumps_wheeldrops if state else None})
        print(f"demo: {step}: truth ({truth[0]:.2f}, {truth[1]:.2f}, {math.degrees(truth[2]):.0f} deg), "
              f"odom drift {dist:.3f} m", flush=True)

    # bob walks the corridor the robot is about to use: send him to the bedroom (test service)
    from florence_sim.srv import SetPerson

    rospy.wait_for_service("/florence_sim/set_person", timeout)
    res = rospy.ServiceProxy("/florence_sim/set_person", SetPerson)(
        "bob", "{path: [[1.0, 7.4], [4.8, 7.4]], speed: 0.4, mode: back_and_forth, pause: 2.0, "
               "shirt: [0.1, 0.3, 0.85]}")
    if not res.success:
        raise ProcessError(f"set_person bob: {res.message}")
    record("start in the living room (bob sent to walk in the bedroom)")
    driver.straight(1.7)
    record("through the door into the corridor")
    driver.turn(-math.pi / 2)
    record("turned right, facing east along the corridor")
    driver.straight(1.2)
    record("along the corridor")
    tilt_pub = rospy.Publisher("/tilt_angle", Float64, queue_size=1, latch=True)
    tilt_pub.publish(Float64(15.0))
    wait_for(lambda: obs.get("/cur_tilt_angle") and abs(obs.get("/cur_tilt_angle").data - 15.0) < 0.1, timeout,
             what="Kinect tilted to 15 deg")
    tilt_pub.publish(Float64(0.0))
    wait_for(lambda: abs(obs.get("/cur_tilt_angle").data) < 0.1, timeout, what="Kinect tilt back to 0")
    record("Kinect tilted up 15 deg and back")
    driver.turn(math.pi / 2)
    record("turned left, facing the corridor's north wall")
    collisions_before = _collisions(rospy, timeout)

    def bumped():
        state = obs.get("/turtlebot_node/sensor_state")
        return state is not None and state.bumps_wheeldrops & 0b11 != 0

    driver.straight(1.0, speed=0.2, until=bumped)
    record("bumped into the corridor wall")
    driver.straight(-0.3, speed=0.2)
    record("backed off")
    collisions = _collisions(rospy, timeout) - collisions_before
    tilt_pub.unregister()

    sim_s, wall_s = obs.now() - t0, time.monotonic() - wall0
    counts = obs.counts()
    rates = {topic: round((counts[topic] - counts0[topic]) / sim_s, 1) for topic in RATES}
    people = obs.get("/people_ground_truth")
    summary = {
        "sim_seconds": round(sim_s, 2), "wall_seconds": round(wall_s, 2),
        "real_time_factor_achieved": round(sim_s / wall_s, 2),
        "collisions_in_scenario": collisions,
        "final_drift_m": rows[-1]["drift_m"], "final_drift_deg": rows[-1]["drift_deg"],
        "rates_hz_sim_time": rates,
        "people": {p.id: [round(p.pose.position.x, 2), round(p.pose.position.y, 2)] for p in people.people}
        if people else {},
    }
    return rows, summary


def run_navigation(rospy, timeout):
    """Scenario 2: move_base goals to room hotspots; returns (rows, checks)."""
    import yaml
    from florence_eval.nav_session import NavSession

    from florence_harness import workspace
    from florence_sim.srv import RemovePerson

    rooms = yaml.safe_load((workspace.root() / "maps" / "apartment" / "rooms.yaml").read_text())["rooms"]
    remove = rospy.ServiceProxy("/florence_sim/remove_person", RemovePerson)
    for person in ("alice", "bob"):
        remove(person)  # person avoidance is the scenario tests' (test_move_base_sim.py)
    session = NavSession()
    if not session.wait_ready(timeout):
        raise ProcessError("move_base's action server did not come up")
    time.sleep(1.0)  # a fresh action client's first goal can be lost while the connections settle
    collisions_before = _collisions(rospy, timeout)
    rows = []
    try:
        for room in NAV_GOALS:
            h = rooms[room]["hotspot"]
            start = session.latest()
            state, text, took, length = session.go(h["x"], h["y"], h["phi"], sim_timeout=max(timeout, 120.0) * 1.5)
            here = session.latest()
            err = math.hypot(here[1] - h["x"], here[2] - h["y"])
            yaw_err = abs(_wrap(here[3] - h["phi"]))
            rows.append({"goal": room, "hotspot": [h["x"], h["y"], h["phi"]], "state": state, "text": text,
                         "sim_time_s": round(took, 2), "driven_m": round(length, 2),
                         "from": [round(v, 2) for v in start[1:4]], "error_m": round(err, 3),
                         "yaw_error_deg": round(math.degrees(yaw_err), 1)})
            print(f"demo: move_base goal {room}: {state} in {took:.1f} s (sim), {length:.1f} m, "
                  f"off by {err:.2f} m / {math.degrees(yaw_err):.0f} deg {text}", flush=True)
    finally:
        session.close()
    collisions = _collisions(rospy, timeout) - collisions_before
    checks = [
        ("every goal SUCCEEDED", all(r["state"] == "SUCCEEDED" for r in rows),
         ", ".join(f"{r['goal']}: {r['state']}" for r in rows)),
        # xy_goal_tolerance 0.25 m of the seed plus amcl's error
        ("every goal reached within 0.35 m", all(r["error_m"] < 0.35 for r in rows),
         ", ".join(f"{r['error_m']} m" for r in rows)),
        ("no collision while navigating", collisions == 0, f"{collisions} collision(s)"),
    ]
    return rows, checks


def _check_running(sim, rospy, timeout):
    """Fail at once (not after a timeout) when the simulator dies at start-up."""
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
        raise ProcessError("florence_sim.launch exited at start-up (see its output above)")


def _collisions(rospy, timeout):
    from std_msgs.msg import UInt32

    return rospy.wait_for_message("/collisions", UInt32, timeout).data


def scenario_passed(rows, summary):
    """What the scenario must show: the robot reached the corridor, bumped once, sensors alive."""
    checks = []
    corridor = rows[3]["truth"]
    checks.append(("robot drove into the corridor", 5.55 < corridor[1] < 6.75, f"truth {corridor}"))
    checks.append(("one collision, bumper pressed", summary["collisions_in_scenario"] == 1
                   and rows[-2]["bumps_wheeldrops"] not in (None, 0),
                   f"{summary['collisions_in_scenario']} collision(s), bumps {rows[-2]['bumps_wheeldrops']}"))
    rates = summary["rates_hz_sim_time"]
    expected = {"/scan": 10.0, "/odom": 30.0, "/camera/depth/image": 15.0, "/turtlebot_node/sensor_state": 10.0,
                "/clock": 100.0}
    for topic, hz in expected.items():
        checks.append((f"{topic} at about {hz:g} Hz (sim time)", abs(rates[topic] - hz) < 0.25 * hz,
                       f"{rates[topic]} Hz"))
    checks.append(("odometry drift below 0.3 m", summary["final_drift_m"] < 0.3, f"{summary['final_drift_m']} m"))
    return checks


def write_report(out_dir, frames, checks, links, master_uri, rows=None, summary=None, scenario_checks=(),
                 nav_rows=(), nav_checks=()):
    os.makedirs(out_dir, exist_ok=True)
    tree = render_tree(frames, ROOT_FRAME)
    passed = all(ok for _, ok, _ in checks)
    scenario_ok = all(ok for _, ok, _ in scenario_checks) and all(ok for _, ok, _ in nav_checks)
    lines = [
        "# Florence demo report",
        "",
        f"- time: {datetime.datetime.now().isoformat(timespec='seconds')}",
        f"- ROS master: {master_uri} (private, stopped at the end)",
        "- ran: turtlebot_control/turtlebot_2dnav_control.launch sim:=true (florence_sim's apartment with 2 "
        "walking people, robot_state_publisher, laser_filter, laser_combinator, pointcloud_to_laserscan, "
        "cmd_vel_mux, velocity_filter, map_server, amcl, move_base)",
        "- not yet in the workspace: the behaviour nodes (florence_locator, follow_me, approach_me, ...)",
        f"- robot links in the URDF: {len(links)}; frames in tf: {len(frames) + 1}",
        f"- frame conventions: {'all passed' if passed else 'FAILED'}",
        f"- scenario: {'all passed' if scenario_ok else 'FAILED'}",
        "",
    ]
    if rows:
        lines += [
            "## Scenario 1: by hand (teleop input of the multiplexer, closed loop on odometry)",
            "",
            f"{summary['sim_seconds']} s simulated in {summary['wall_seconds']} s "
            f"(real-time factor {summary['real_time_factor_achieved']}); "
            f"collisions: {summary['collisions_in_scenario']}; final odometry drift "
            f"{summary['final_drift_m']} m, {summary['final_drift_deg']} deg.",
            "",
            "| step | sim t [s] | ground truth x, y [m], yaw [rad] | odometry x, y [m], yaw [rad] | drift [m] | "
            "drift [deg] | bumpers |",
            "| --- | --- | --- | --- | --- | --- | --- |",
            *[f"| {r['step']} | {r['sim_time_s']} | {r['truth']} | {r['odom']} | {r['drift_m']} | {r['drift_deg']} | "
              f"{r['bumps_wheeldrops']} |" for r in rows],
            "",
            "Sensor rates over the scenario, in simulated time:",
            "",
            "| topic | Hz |",
            "| --- | --- |",
            *[f"| `{topic}` | {hz} |" for topic, hz in summary["rates_hz_sim_time"].items()],
            "",
            f"People at the end: {summary['people']}",
            "",
            "## Scenario checks",
            "",
            *[f"- [{'x' if ok else ' '}] {name}: {detail}" for name, ok, detail in scenario_checks],
            "",
        ]
    if nav_rows:
        lines += [
            "## Scenario 2: move_base goals to room hotspots (people sent away)",
            "",
            "| goal | from x, y, yaw | outcome | sim time [s] | driven [m] | final error [m] | yaw error [deg] |",
            "| --- | --- | --- | --- | --- | --- | --- |",
            *[f"| {r['goal']} {r['hotspot']} | {r['from']} | {r['state']} {r['text']} | {r['sim_time_s']} | "
              f"{r['driven_m']} | {r['error_m']} | {r['yaw_error_deg']} |" for r in nav_rows],
            "",
            "## Navigation checks",
            "",
            *[f"- [{'x' if ok else ' '}] {name}: {detail}" for name, ok, detail in nav_checks],
            "",
        ]
    lines += [
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
    atomic_write(os.path.join(out_dir, "report.md"), report.encode())
    data = {
        child: {"parent": link.parent, "translation": list(link.translation), "rotation_xyzw": list(link.rotation)}
        for child, link in frames.items()
    }
    atomic_write(os.path.join(out_dir, "frames.json"),
                 json.dumps({"root": ROOT_FRAME, "frames": data, "checks": checks}, indent=2).encode())
    if rows:
        scenario = {"steps": rows, "summary": summary, "checks": list(scenario_checks),
                    "navigation": {"goals": list(nav_rows), "checks": list(nav_checks)}}
        atomic_write(os.path.join(out_dir, "scenario.json"), json.dumps(scenario, indent=2).encode())
    return report, passed and scenario_ok


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", default="demo_output", help="directory for report.md, frames.json, scenario.json")
    parser.add_argument("--rviz", choices=("auto", "yes", "no"), default="auto",
                        help="open rviz (auto: only when DISPLAY is set)")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds to wait for each step")
    parser.add_argument("--real-time-factor", type=float, default=None,
                        help="simulation speed (default: 1 with rviz, 3 headless)")
    args = parser.parse_args(argv)
    show = args.rviz == "yes" or (args.rviz == "auto" and bool(os.environ.get("DISPLAY")))
    rtf = args.real_time_factor if args.real_time_factor is not None else (1.0 if show else 3.0)

    # SIGTERM (e.g. from `timeout` or a supervisor) must still stop every child below.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    master = RosMaster().start()
    processes = []
    try:
        os.environ.update({k: v for k, v in master.env().items() if k.startswith("ROS_")})
        print(f"demo: private ROS master at {master.uri}", flush=True)
        x, y, yaw = START
        processes.append(roslaunch(master, "turtlebot_control", "turtlebot_2dnav_control.launch", "sim:=true",
                                   f"real_time_factor:={rtf}", f"x:={x}", f"y:={y}", f"yaw:={yaw}"))

        import rospy

        rospy.init_node("florence_demo", disable_signals=True)
        sim = processes[0]
        wait_for(lambda: (rospy.has_param("/florence_sim/world") and rospy.has_param("/robot_description"))
                 or not sim.running(), args.timeout, what="florence_sim.launch started")
        urdf = rospy.get_param("/robot_description")
        _check_running(sim, rospy, args.timeout)
        rviz = None
        if show:
            import rospkg

            config = os.path.join(rospkg.RosPack().get_path("florence_sim"), "rviz", "florence_sim.rviz")
            rviz = ManagedProcess(["rviz", "-d", config], env=master.env(), name="rviz")
            processes.append(rviz)
            print("demo: rviz is open; the scenario runs while you watch", flush=True)
        links = _links_of(urdf)
        frames = read_tf_tree(rospy, links, args.timeout)
        checks = check_conventions(frames)
        obs = Observer(rospy)
        rows, summary = run_scenario(rospy, obs, args.timeout)
        obs.close()
        scenario_checks = scenario_passed(rows, summary)
        nav_rows, nav_checks = run_navigation(rospy, args.timeout)
        report, passed = write_report(args.output, frames, checks, links, master.uri, rows, summary, scenario_checks,
                                      nav_rows, nav_checks)
        print(report, flush=True)
        print(f"demo: report written to {os.path.join(os.path.abspath(args.output), 'report.md')}", flush=True)

        if rviz is not None:
            print("demo: rviz is open; close its window (or press Ctrl-C) to end the demo", flush=True)
            rviz.proc.wait()
        rospy.signal_shutdown("demo over")
        return 0 if passed else 1
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
