"""`make demo` runs for real: the demo process starts its own master and the simulator,
reads the live tf tree, drives the scripted scenario and writes a report whose checks passed."""

import json
import subprocess
import sys

import pytest


@pytest.mark.scenario
@pytest.mark.slow
def test_demo_writes_report_from_live_tf(tmp_path):
    out = tmp_path / "demo"
    result = subprocess.run(
        [sys.executable, "-m", "florence_scenarios.demo", "--output", str(out), "--rviz", "no", "--timeout", "120"],
        capture_output=True, text=True, timeout=600, check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    report = (out / "report.md").read_text()
    assert "Frame conventions (live tf): all passed" in report
    data = json.loads((out / "frames.json").read_text())
    assert data["frames"]["base_laser_link"]["parent"] == "plate_1_link"
    assert len(data["frames"]) >= 30
    assert not list(out.glob("*.tmp")), "temporary files left behind"
    assert "Scenario checks: all passed" in report and "Navigation checks: all passed" in report
    scenario = json.loads((out / "scenario.json").read_text())
    assert scenario["summary"]["collisions_in_scenario"] == 0
    assert 5.55 < scenario["steps"]["corridor"]["truth"][1] < 6.75, "the robot reached the corridor"
    assert scenario["summary"]["rates_hz_sim_time"]["/scan"] == pytest.approx(10.0, rel=0.25)
    checks = scenario["checks"]
    assert checks["Scenario checks"]["stopped short of the wall: no collision, bumper free, within 0.15 m"]["passed"]
    assert checks["Navigation checks"]["no collision while navigating"]["passed"]
    assert all(c["passed"] for section in checks.values() for c in section.values()), checks
    goals = scenario["navigation"]["goals"]
    assert list(goals) == ["kitchen", "bedroom", "living_room"]
    assert all(g["state"] == "SUCCEEDED" and g["error_m"] < 0.35 for g in goals.values()), goals


@pytest.mark.scenario
def test_demo_stopped_by_sigterm_leaves_no_process(tmp_path):
    """A demo ended by SIGTERM (CI timeout, `timeout`, a supervisor) stops its master and launch."""
    import os
    import signal

    from florence_common.processes import ManagedProcess, descendant_pids, pid_alive, wait_for

    # A stand-in viewer that stays open, so the demo is certainly still running when signalled.
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "rviz").write_text("#!/bin/sh\nexec sleep 600\n")
    (bin_dir / "rviz").chmod(0o755)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}")
    demo = ManagedProcess([sys.executable, "-m", "florence_scenarios.demo", "--output", str(tmp_path / "out"),
                           "--rviz", "yes", "--timeout", "120"], env=env, name="demo")
    children = []
    try:
        wait_for(lambda: "rviz is open" in demo.output(), 120.0, what="demo waiting on rviz")
        assert demo.running()
        children = descendant_pids(demo.pid)
        assert children, "the demo started no child process"
        os.kill(demo.pid, signal.SIGTERM)
        demo.proc.wait(60.0)
        wait_for(lambda: not any(pid_alive(p) for p in children), 30.0, what="children of the demo gone")
    finally:
        demo.stop()
        for pid in children:  # survivors of a failed run: this test started them, it stops them
            if pid_alive(pid):
                os.kill(pid, signal.SIGKILL)
