"""`make demo` runs for real: the demo process starts its own master and the description,
reads the live tf tree and writes a report whose checks passed."""

import json
import subprocess
import sys

import pytest


@pytest.mark.ros
def test_demo_writes_report_from_live_tf(tmp_path):
    out = tmp_path / "demo"
    result = subprocess.run(
        [sys.executable, "-m", "florence_bringup.demo", "--output", str(out), "--rviz", "no", "--timeout", "120"],
        capture_output=True, text=True, timeout=300, check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    report = (out / "report.md").read_text()
    assert "frame conventions: all passed" in report
    data = json.loads((out / "frames.json").read_text())
    assert data["frames"]["base_laser_link"]["parent"] == "plate_1_link"
    assert len(data["frames"]) >= 30
    assert not list(out.glob("*.tmp")), "temporary files left behind"
