"""The isolating test runner: which tests share a process, what each process is given."""

import subprocess
import sys
import textwrap

import pytest

from florence_harness.isolated import group_items, junit_counts, options_only

pytestmark = pytest.mark.unit


def test_unit_tests_share_one_process_and_each_ros_module_has_its_own():
    items = [
        ("src/a/test/test_core.py::test_x", {"unit"}),
        ("src/a/test/test_node.py::test_starts", {"ros"}),
        ("src/a/test/test_node.py::test_parses", {"unit"}),
        ("src/b/test/test_sim.py::test_drive", {"scenario", "slow"}),
        ("src/a/test/test_node.py::test_stops", {"ros"}),
        ("src/c/test/test_pty.py::test_io", {"protocol"}),
    ]
    groups = group_items(items)
    assert [g.name for g in groups] == ["unit tests", "src/a/test/test_node.py", "src/b/test/test_sim.py",
                                        "src/c/test/test_pty.py"]
    assert groups[0].node_ids == ["src/a/test/test_core.py::test_x", "src/a/test/test_node.py::test_parses"]
    assert groups[1].node_ids == ["src/a/test/test_node.py::test_starts", "src/a/test/test_node.py::test_stops"]


def test_no_unit_tests_means_no_unit_process():
    assert [g.name for g in group_items([("t.py::a", {"ros"})])] == ["t.py"]
    assert group_items([]) == []


def test_paths_and_node_ids_are_dropped_options_kept(tmp_path):
    folder = tmp_path / "pkg"
    folder.mkdir()
    args = ["-m", "unit", str(folder), "-k", "minimal", "x.py::test_y", "-x"]
    assert options_only(args) == ["-m", "unit", "-k", "minimal", "-x"]


def test_junit_counts_reads_failures_and_errors(tmp_path):
    xml = tmp_path / "r.xml"
    xml.write_text(textwrap.dedent("""\
        <testsuites><testsuite tests="4" failures="1" errors="1" skipped="1">
          <testcase classname="a.test_b" name="test_ok"/>
          <testcase classname="a.test_b" name="test_bad"><failure message="no"/></testcase>
          <testcase classname="a.test_b" name="test_broken"><error message="setup"/></testcase>
          <testcase classname="a.test_b" name="test_skip"><skipped/></testcase>
        </testsuite></testsuites>"""))
    assert junit_counts(xml) == (4, 2, 1, ["a.test_b::test_bad", "a.test_b::test_broken"])
    assert junit_counts(tmp_path / "missing.xml") == (0, 0, 0, [])


def test_a_failing_module_fails_the_run_and_the_others_still_run(tmp_path):
    (tmp_path / "conftest.py").write_text("")
    (tmp_path / "pyproject.toml").write_text('[tool.pytest.ini_options]\nmarkers = ["ros: x", "unit: y"]\n')
    (tmp_path / "test_one.py").write_text("import pytest\n\n@pytest.mark.ros\ndef test_fails():\n    assert False\n")
    (tmp_path / "test_two.py").write_text("import pytest\n\n@pytest.mark.ros\ndef test_passes():\n    pass\n")
    proc = subprocess.run([sys.executable, "-m", "florence_harness.isolated",
                           str(tmp_path)], cwd=tmp_path, capture_output=True, text=True, check=False, timeout=120)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "2 processes, 2 tests, 1 failed" in proc.stdout
    assert "FAILED test_one::test_fails" in proc.stdout
    empty = subprocess.run([sys.executable, "-m", "florence_harness.isolated", str(tmp_path), "-k", "nothing"],
                           cwd=tmp_path, capture_output=True, text=True, check=False, timeout=120)
    assert empty.returncode == 5, empty.stdout
