"""The demo's report: ``report.md`` (for people), ``frames.json`` and ``scenario.json`` (for
programs), each written atomically. ROS-free."""

import datetime
import json
import os

from florence_common.files import atomic_write
from florence_scenarios.tf_report import render_tree

ROOT_FRAME = "base_footprint"


def _steps_table(steps, summary):
    return [
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
          f"{r['bumps_wheeldrops']} |" for r in steps.rows.values()],
        "",
        "Sensor rates over the scenario, in simulated time:",
        "",
        "| topic | Hz |",
        "| --- | --- |",
        *[f"| `{topic}` | {hz} |" for topic, hz in summary["rates_hz_sim_time"].items()],
        "",
        f"People at the end: {summary['people']}",
        "",
    ]


def _goals_table(goals):
    return [
        "## Scenario 2: move_base goals to room hotspots (people sent away)",
        "",
        "| goal | from x, y, yaw | outcome | sim time [s] | driven [m] | final error [m] | yaw error [deg] |",
        "| --- | --- | --- | --- | --- | --- | --- |",
        *[f"| {g['goal']} {g['hotspot']} | {g['from']} | {g['state']} {g['text']} | {g['sim_time_s']} | "
          f"{g['driven_m']} | {g['error_m']} | {g['yaw_error_deg']} |" for g in goals.values()],
        "",
    ]


def write(out_dir, master_uri, frames, links, sections, steps=None, summary=None, goals=None):
    """Write the three files; ``sections`` maps a heading to its Checks ("Frame conventions (live
    tf)", "Scenario checks", "Navigation checks"). Returns (report text, every check passed)."""
    os.makedirs(out_dir, exist_ok=True)
    passed = all(checks.passed for checks in sections.values())
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
        *[f"- {heading}: {'all passed' if checks.passed else 'FAILED: ' + ', '.join(checks.failed())}"
          for heading, checks in sections.items()],
        "",
    ]
    if steps is not None:
        lines += _steps_table(steps, summary)
    if goals:
        lines += _goals_table(goals)
    for heading, checks in sections.items():
        lines += [f"## {heading}", "", checks.markdown(), ""]
    lines += ["## tf tree", "", "```", render_tree(frames, ROOT_FRAME), "```", ""]
    report = "\n".join(lines)
    atomic_write(os.path.join(out_dir, "report.md"), report.encode())
    data = {child: {"parent": link.parent, "translation": list(link.translation), "rotation_xyzw": list(link.rotation)}
            for child, link in frames.items()}
    conventions = next(iter(sections.values()))
    atomic_write(os.path.join(out_dir, "frames.json"),
                 json.dumps({"root": ROOT_FRAME, "frames": data, "checks": conventions.as_json()}, indent=2).encode())
    if steps is not None:
        scenario = {"steps": steps.rows, "summary": summary,
                    "checks": {heading: checks.as_json() for heading, checks in sections.items()},
                    "navigation": {"goals": goals or {}}}
        atomic_write(os.path.join(out_dir, "scenario.json"), json.dumps(scenario, indent=2).encode())
    return report, passed
