"""The demo's report: ``report.md`` and a self-contained ``report.html`` (florence_scenarios.document)
with its pictures (florence_scenarios.figures), ``day.json`` and ``frames.json`` for programs, each
written atomically. ROS-free: it renders a record the demo collected.

The record (a dict):
- ``summary``: {"command", "real_time_factor", "achieved_real_time_factor", "sim_seconds",
  "wall_seconds", "started"};
- ``steps``: [Step.as_json()]; ``calls``: [{"t", "service", "args", "success", "message"}];
- ``robot_truth``, ``robot_amcl``: [(x, y)] [m]; ``people``: {id: [(x, y)]}; ``marks``: [(x, y, label)];
- ``follow``: {"t": [s], "d": [m], "desired": m} (the distance to the user while following);
- ``least``: judge.least_distances rows; ``cpu``: {node: cores}, ``cpu_total``: cores;
- ``frames``: {child: FrameLink}, ``links``: URDF link names;
- ``sections``: {heading: Checks}.
"""

import json
import math
import os

from florence_common.files import atomic_write
from florence_scenarios import figures
from florence_scenarios.document import Document
from florence_scenarios.tf_report import render_tree

ROOT_FRAME = "base_footprint"
CPU_TARGET = 1.2  # [cores] the whole system at real time (issue 24)
SIMULATOR = "/florence_sim"  # stands in for the robot's base, laser and Kinect and their drivers


def robot_cpu(cpu, total):
    """Cores of every node but the simulator's (what the robot runs besides its drivers), or None
    when the simulator was not measured."""
    return total - cpu[SIMULATOR] if SIMULATOR in cpu and total is not None else None


def _cpu_line(record):
    total = record.get("cpu_total", math.nan)
    line = (f"CPU of the whole system at real time: {total:.2f} cores (target <= {CPU_TARGET}; every node summed, "
            f"CPU seconds per simulated second)")
    robot = robot_cpu(record.get("cpu", {}), record.get("cpu_total"))
    if robot is not None:
        line += (f"; without florence_sim, which stands in for the base, the sensors and their drivers: "
                 f"{robot:.2f} cores (the drivers' own CPU on the robot is not measured)")
    return line


def passed(sections):
    return all(checks.passed for checks in sections.values())


def write(out_dir, record, grid=None):
    """Write every file into ``out_dir``; ``grid`` (a map_server GridMap) for the map picture.
    Returns (Markdown text, every check passed)."""
    os.makedirs(out_dir, exist_ok=True)
    sections = record["sections"]
    ok = passed(sections)
    s = record["summary"]
    doc = Document("Florence demo: a scripted day")
    n_checks = sum(len(c) for c in sections.values())
    n_failed = sum(len(c.failed()) for c in sections.values())
    doc.bullets([
        f"outcome: {'every check passed' if ok else f'{n_failed} of {n_checks} checks FAILED'}",
        f"started: {s.get('started', '')}",
        f"system: `{s.get('command', '')}` (one launch, headless; a private ROS master, stopped at the end)",
        f"simulation: {s.get('sim_seconds', 0):.0f} s simulated in {s.get('wall_seconds', 0):.0f} s wall "
        f"(real-time factor asked {s.get('real_time_factor')}, achieved {s.get('achieved_real_time_factor', 0):.2f})",
        _cpu_line(record),
        *[f"{heading}: {'all passed' if checks.passed else 'FAILED: ' + ', '.join(checks.failed())}"
          for heading, checks in sections.items()],
    ])

    doc.heading("The day, step by step")
    doc.table(["step", "request", "outcome", "sim time [s]", "vs ground truth"],
              [[st["name"], st["request"], st["outcome"], round(st["seconds"], 1), st["error"]]
               for st in record["steps"]])

    if grid is not None:
        png = os.path.join(out_dir, "paths.png")
        figures.paths_over_map(png, grid, record.get("robot_truth", []), record.get("robot_amcl", []),
                               record.get("people", {}), record.get("marks", []),
                               "the robot (true and amcl's estimate) and the people over the day")
        doc.image("paths.png", "The apartment's map with the robot's true path (blue), amcl's estimate (orange, "
                  "dashed), the people's true paths, and where each step ended")

    doc.heading("Service calls (florenceLocator)")
    doc.table(["sim t [s]", "service", "arguments", "success", "message"],
              [[c["t"], c["service"], ", ".join(str(a) for a in c["args"]), c["success"], c["message"]]
               for c in record.get("calls", [])])

    follow = record.get("follow") or {}
    doc.heading("Following the user")
    if follow.get("t"):
        series = {"robot to the user (ground truth)": (follow["t"], follow["d"])}
        figures.timeline(os.path.join(out_dir, "follow.png"), series, "distance [m]", [(0.45, "personal space 0.45 m"),
                                          (follow.get("desired", 1.0), f"asked {follow.get('desired', 1.0)} m")],
                         "centre distance while follow_me follows the user to the bedroom")
        doc.image("follow.png", "The distance from the robot to the user over simulated time while following")
    else:
        doc.paragraph("No following was recorded (the step did not run).")

    doc.heading("Least distance to each person")
    least = record.get("least", [])
    doc.paragraph("Centre to centre, ground truth, per step; 'asked' marks the steps whose end the day asked to "
                  "be near that person (an approach), which are judged by their own distance instead of 0.45 m.")
    doc.table(["step", "person", "least [m]", "at sim t [s]", ""],
              [[r["window"], r["person"], round(r["least_m"], 3), round(r["at_s"], 1), "asked" if r["excused"] else
                ("OK" if r["least_m"] >= 0.45 else "TOO NEAR")] for r in least])

    cpu = record.get("cpu", {})
    doc.heading("CPU per node")
    if cpu:
        figures.bars(os.path.join(out_dir, "cpu.png"), cpu, "cores at real time (CPU s per simulated s)",
                     f"every node of the system, {record.get('cpu_total', 0):.2f} cores in all", limit=CPU_TARGET)
        doc.image("cpu.png", f"CPU per node (the dotted line: the whole system's target, {CPU_TARGET} cores)")
        doc.table(["node", "cores"], [[n, round(v, 3)] for n, v in sorted(cpu.items(), key=lambda kv: -kv[1])]
                  + [["all nodes", round(record.get("cpu_total", 0), 3)]])
        doc.paragraph("Measured over the day at the achieved real-time factor (CPU time from /proc of each "
                      "node's process, through the master): CPU seconds per simulated second are the cores the "
                      "node needs at real time. A node restarted during the day counts both its processes.")

    doc.heading("Checks")
    for heading, checks in sections.items():
        doc.heading(heading, level=3)
        doc.checks(checks)

    frames = record.get("frames") or {}
    if frames:
        doc.heading("tf tree (live)")
        doc.code(render_tree(frames, ROOT_FRAME))

    text = doc.write(out_dir)
    day = {"summary": s, "steps": record["steps"], "calls": record.get("calls", []), "least": least,
           "cpu": cpu, "cpu_total": record.get("cpu_total"), "follow": follow,
           "checks": {heading: checks.as_json() for heading, checks in sections.items()}, "passed": ok}
    atomic_write(os.path.join(out_dir, "day.json"), json.dumps(day, indent=2, default=str).encode())
    if frames:
        data = {child: {"parent": link.parent, "translation": list(link.translation),
                        "rotation_xyzw": list(link.rotation)} for child, link in frames.items()}
        atomic_write(os.path.join(out_dir, "frames.json"),
                     json.dumps({"root": ROOT_FRAME, "frames": data, "links": record.get("links", [])},
                                indent=2).encode())
    return text, ok
