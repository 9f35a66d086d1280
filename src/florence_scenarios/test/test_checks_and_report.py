"""The demo's named checks, its by-hand judgement and its report files (no ROS)."""

import json

import pytest
from florence_scenarios.checks import Checks
from florence_scenarios.scenarios import EXPECTED_RATES, by_hand_checks, odom_drift
from florence_scenarios.tf_report import FrameLink, check_conventions

from florence_scenarios import report

pytestmark = pytest.mark.unit


def test_checks_are_addressed_by_name():
    checks = Checks()
    checks.add("a", True, "fine")
    checks.add("b", False, "broken")
    assert checks["b"].detail == "broken" and "a" in checks
    assert not checks.passed and checks.failed() == ["b"]
    assert checks.as_json() == {"a": {"passed": True, "detail": "fine"}, "b": {"passed": False, "detail": "broken"}}
    assert checks.markdown() == "- [x] a: fine\n- [ ] b: broken"
    with pytest.raises(ValueError, match="twice"):
        checks.add("a", True)


class FakeSteps:
    def __init__(self, rows):
        self.rows = rows

    def __getitem__(self, key):
        return self.rows[key]


def _run(corridor_y=6.1, bumps=0, bumper=0, wall_y=6.55, scan_hz=10.0, drift=0.05):
    steps = FakeSteps({"corridor": {"truth": [4.0, corridor_y, 0.0]},
                       "bump": {"bumps_wheeldrops": bumper, "truth": [4.0, wall_y, 1.57]}})
    rates = dict(EXPECTED_RATES, **{"/scan": scan_hz})
    summary = {"collisions_in_scenario": bumps, "rates_hz_sim_time": rates, "final_drift_m": drift}
    return by_hand_checks(steps, summary)


def test_by_hand_checks_pass_on_a_good_run_and_name_what_failed():
    assert _run().passed
    assert _run(corridor_y=5.0).failed() == ["robot drove into the corridor"]
    at_wall = ["stopped short of the wall: no collision, bumper free, within 0.15 m"]
    assert _run(bumps=1).failed() == at_wall
    assert _run(bumper=1).failed() == at_wall
    assert _run(wall_y=6.3).failed() == at_wall  # stopped 0.33 m short: too timid
    assert _run(wall_y=6.65).failed() == at_wall  # the body inside the wall
    assert _run(scan_hz=5.0).failed() == ["/scan at about 10 Hz (sim time)"]
    assert _run(drift=0.4).failed() == ["odometry drift below 0.3 m"]


def test_odom_drift_carries_odometry_through_the_start_pose():
    import math

    start = (2.0, 1.0, math.pi / 2)
    # 1 m forward by odometry from a start facing +y ends at (2, 2)
    assert odom_drift(start, (1.0, 0.0, 0.0), (2.0, 2.0, math.pi / 2)) == pytest.approx((0.0, 0.0), abs=1e-9)
    dist, ang = odom_drift(start, (1.0, 0.0, 0.1), (2.1, 2.0, math.pi / 2))
    assert dist == pytest.approx(0.1) and ang == pytest.approx(0.1)


def test_report_files(tmp_path):
    frames = {"base_link": FrameLink("base_footprint", (0, 0, 0.017), (0, 0, 0, 1))}
    sections = {"Frame conventions (live tf)": check_conventions(frames), "Navigation checks": Checks()}
    sections["Navigation checks"].add("every goal SUCCEEDED", True, "kitchen: SUCCEEDED")
    text, passed = report.write(str(tmp_path), "http://127.0.0.1:1/", frames, ["base_link"], sections)
    assert not passed  # the laser frames are missing from this tree
    assert "- Frame conventions (live tf): FAILED: laser frames present" in text
    assert "- [x] every goal SUCCEEDED: kitchen: SUCCEEDED" in text
    data = json.loads((tmp_path / "frames.json").read_text())
    assert data["frames"]["base_link"]["parent"] == "base_footprint"
    assert data["checks"]["laser frames present"]["passed"] is False
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frames.json", "report.md"]
