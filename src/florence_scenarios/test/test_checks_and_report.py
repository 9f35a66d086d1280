"""The demo's named checks, the day's judgement against ground truth and its report files (no ROS)."""

import base64
import json
import math

import numpy as np
import pytest
from florence_scenarios.checks import Checks
from florence_scenarios.tf_report import FrameLink, check_conventions

from florence_scenarios import day, judge, report

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


def track_line(t0, t1, x0, x1, y=0.0, n=101):
    """Robot rows (t, x, y, yaw, v, w) driving along x."""
    t = np.linspace(t0, t1, n)
    x = np.linspace(x0, x1, n)
    return np.column_stack([t, x, np.full(n, y), np.zeros(n), np.full(n, 0.1), np.zeros(n)])


def people(ts, **where):
    """A people log [(t, {id: (x, y, yaw, posture)})] of people standing still."""
    return [(t, {pid: (*xy, 0.0, "standing") for pid, xy in where.items()}) for t in ts]


def test_distance_series_interpolates_the_person_at_robot_stamps():
    track = track_line(0.0, 10.0, 0.0, 5.0)
    person = np.array([[0.0, 6.0, 0.0], [10.0, 6.0, 0.0]])
    t, d = judge.distance_series(track, person)
    assert len(t) == 101 and d[0] == pytest.approx(6.0) and d[-1] == pytest.approx(1.0)
    assert judge.distance_series(track[:0], person)[0].size == 0


def test_least_distances_per_step_and_the_excused_approach():
    track = np.vstack([track_line(0.0, 10.0, 0.0, 2.6), track_line(10.1, 20.0, 2.6, 0.0)])
    log = people(np.arange(0.0, 20.5, 0.5), alice=(3.0, 0.0), bob=(0.0, 3.0))
    least = judge.least_distances(track, log, [("gotoUser", 0.0, 10.0), ("gotoRoom", 10.1, 20.0)],
                                  excused={("gotoUser", "alice")})
    rows = {(r["window"], r["person"]): r for r in least}
    assert rows[("gotoUser", "alice")]["least_m"] == pytest.approx(0.4, abs=1e-6)
    assert rows[("gotoUser", "alice")]["excused"]
    assert rows[("gotoRoom", "alice")]["least_m"] == pytest.approx(0.4, abs=1e-6)
    kept, worst, row = judge.personal_space_kept(least)
    assert not kept and row["window"] == "gotoRoom" and row["person"] == "alice"
    kept, worst, _ = judge.personal_space_kept([r for r in least if r["person"] == "bob"])
    assert kept and worst == pytest.approx(3.0)


def test_moved_gives_the_net_distance_and_turn():
    track = track_line(0.0, 2.0, 1.0, 1.5)
    track[:, 3] = np.linspace(0.0, 1.2, len(track))
    dist, turn = judge.moved(track, 0.0, 2.0)
    assert dist == pytest.approx(0.5) and turn == pytest.approx(1.2)
    track[:, 3] = np.linspace(3.0, 3.4, len(track))  # across +-pi
    track[:, 3] = np.angle(np.exp(1j * track[:, 3]))
    assert judge.moved(track, 0.0, 2.0)[1] == pytest.approx(0.4)


def test_cpu_per_node_counts_a_restarted_node_twice_and_divides_by_sim_time():
    first = {"/amcl": {10: 5.0}, "/florence_locator": {11: 1.0}}
    last = {"/amcl": {10: 25.0}, "/florence_locator": {11: 3.0, 12: 1.0}, "/new": {13: 2.0}}
    cores, total = judge.cpu_per_node(first, last, 100.0)
    assert cores == {"/amcl": pytest.approx(0.2), "/florence_locator": pytest.approx(0.03), "/new": pytest.approx(0.02)}
    assert total == pytest.approx(0.25)


def record(failed=False):
    day = Checks()
    day.add("gotoUser: SUCCEEDED", not failed, "SUCCEEDED")
    frames = {"base_link": FrameLink("base_footprint", (0, 0, 0.017), (0, 0, 0, 1))}
    return {
        "summary": {"command": "roslaunch florence_bringup florence_bringup.launch sim:=true", "real_time_factor": 2.0,
                    "achieved_real_time_factor": 1.7, "sim_seconds": 300.0, "wall_seconds": 176.0, "started": "now"},
        "steps": [{"name": "gotoUser", "request": "gotoUser", "outcome": "SUCCEEDED", "seconds": 61.2, "start_s": 3.0,
                   "error": "0.52 m from the user", "data": {}}],
        "calls": [{"t": 3.0, "service": "gotoUser", "args": [], "success": True, "message": "accepted"},
                  {"t": 4.0, "service": "setUserPosXYPhi", "args": [math.nan, 2.0, 0.0], "success": False,
                   "message": "x must be finite"}],
        "robot_truth": [(6.5, 2.5), (3.5, 2.5)], "robot_amcl": [(6.5, 2.55), (3.5, 2.45)],
        "people": {"alice": [(3.0, 2.4)], "bob": [(1.0, 1.2)]}, "marks": [(3.5, 2.5, "gotoUser")],
        "follow": {"t": [0.0, 1.0, 2.0], "d": [0.6, 0.9, 1.1], "desired": 1.0},
        "least": [{"window": "gotoUser", "person": "bob", "least_m": 2.1, "at_s": 50.0, "excused": False}],
        "cpu": {"/move_base": 0.3, "/florence_sim": 0.2}, "cpu_total": 0.5, "frames": frames, "links": ["base_link"],
        "sections": {"Frame conventions (live tf)": check_conventions(frames), "The day": day},
    }


def grid():
    from map_server.mapfile import GridMap

    data = np.zeros((100, 80), np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return GridMap(data, 0.1, (0.0, 0.0, 0.0))


def test_report_files(tmp_path):
    text, passed = report.write(str(tmp_path), record(), grid())
    assert not passed  # the laser frames are missing from this tree
    assert "Frame conventions (live tf): FAILED: laser frames present" in text
    assert "- [x] gotoUser: SUCCEEDED: SUCCEEDED" in text
    assert "| gotoUser | gotoUser | SUCCEEDED | 61.2 | 0.52 m from the user |" in text
    assert "x must be finite" in text and "0.5 cores" in text.replace("0.50 cores", "0.5 cores")
    assert "without florence_sim, which stands in for the base, the sensors and their drivers: 0.30 cores" in text
    for png in ("paths.png", "follow.png", "cpu.png"):
        assert (tmp_path / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert "![" in text and png in text
    html = (tmp_path / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 3  # self-contained
    inlined = html.split("data:image/png;base64,")[1].split('"')[0]
    assert base64.b64decode(inlined)[:4] == b"\x89PNG"
    day = json.loads((tmp_path / "day.json").read_text())
    assert day["passed"] is False and day["checks"]["The day"]["gotoUser: SUCCEEDED"]["passed"]
    assert day["cpu_total"] == 0.5
    frames = json.loads((tmp_path / "frames.json").read_text())
    assert frames["frames"]["base_link"]["parent"] == "base_footprint"
    assert not list(tmp_path.glob("*.tmp"))


def test_report_names_failed_checks(tmp_path):
    rec = record(failed=True)
    rec["sections"].pop("Frame conventions (live tf)")
    text, passed = report.write(str(tmp_path), rec, None)
    assert not passed
    assert "1 of 1 checks FAILED" in text and "The day: FAILED: gotoUser: SUCCEEDED" in text
    assert not (tmp_path / "paths.png").exists()


def test_not_following_gives_the_spans_follow_me_did_something_else():
    states = [(1.0, "following 3 at 1.00 m"), (4.0, "searching for 3, unseen 0.3 s"),
              (4.5, "searching for 3, unseen 0.8 s"), (6.0, "following 3 at 1.40 m"),
              (9.0, "searching for 3, unseen 0.2 s")]
    assert day.not_following(states, 2.0, 10.0) == [(4.0, 6.0, "searching for 3, unseen 0.3 s"),
                                                      (9.0, 10.0, "searching for 3, unseen 0.2 s")]
    assert day.not_following(states, 4.2, 5.0) == [(4.2, 5.0, "searching for 3, unseen 0.3 s")]  # held from before
    assert day.not_following(states, 6.5, 8.0) == []
    assert day.not_following([], 0.0, 1.0) == []
