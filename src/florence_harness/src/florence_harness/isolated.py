"""Run the test suite with one process, and so one private rosmaster, per ROS test module.

rospy initialises once per process, so every test in one pytest process shares one master:
its parameters, latched topics, tf and /use_sim_time. A module that leaves any of them behind
changes the modules after it, and the suite then fails in ways no module shows alone. This
runner collects the tests once (with the caller's pytest arguments), runs every `unit` test in
one process without a master, and every module with `ros`, `protocol` or `scenario` tests in
a process of its own, one after the other (timing-sensitive tests never share the two cores
with another module). It prints one line per process and a summary of the failures, and exits
non-zero if any process failed or nothing was collected (pytest's exit code 5).

    /usr/bin/python3 -m florence_harness.isolated [pytest arguments]
"""

import contextlib
import io
import os
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

ROS_TIERS = ("ros", "protocol", "scenario")
NO_TESTS = 5  # pytest's exit code when nothing was collected


@dataclass
class Group:
    """Tests that run in one pytest process."""

    name: str
    node_ids: list = field(default_factory=list)


def group_items(items):
    """Split collected tests, given as (node_id, marker names), into processes.

    Returns the unit group first (None if empty), then one group per module holding tests of
    a ROS tier, in collection order. A module's unit tests stay with the other unit tests.
    """
    unit = Group("unit tests")
    modules = {}
    for node_id, markers in items:
        if any(m in ROS_TIERS for m in markers):
            path = node_id.split("::", 1)[0]
            modules.setdefault(path, Group(path)).node_ids.append(node_id)
        else:
            unit.node_ids.append(node_id)
    return ([unit] if unit.node_ids else []) + list(modules.values())


class _Recorder:
    """pytest plugin: the collected items with their marker names."""

    def __init__(self):
        self.items = []

    def pytest_collection_finish(self, session):
        self.items = [(item.nodeid, {m.name for m in item.iter_markers()}) for item in session.items]


def collect(args):
    """Collect in this process (no test runs, no rospy node). Returns (exit code, items)."""
    import pytest

    recorder = _Recorder()
    listing = io.StringIO()
    with contextlib.redirect_stdout(listing):
        code = int(pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", *args], plugins=[recorder]))
    if code != 0:
        print(listing.getvalue(), flush=True)  # the collection errors
    return code, recorder.items


def junit_counts(path):
    """(tests, failures + errors, skipped, failed node names) from a junit XML file."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return 0, 0, 0, []
    suites = [root] if root.tag == "testsuite" else list(root.iter("testsuite"))
    tests = failed = skipped = 0
    names = []
    for suite in suites:
        tests += int(suite.get("tests", 0))
        failed += int(suite.get("failures", 0)) + int(suite.get("errors", 0))
        skipped += int(suite.get("skipped", 0))
        for case in suite.iter("testcase"):
            if case.find("failure") is not None or case.find("error") is not None:
                names.append(f"{case.get('classname')}::{case.get('name')}")
    return tests, failed, skipped, names


def options_only(args):
    """The caller's arguments without the paths and node ids (each process gets its own)."""
    out = []
    for arg in args:
        if not arg.startswith("-") and (os.path.exists(arg.split("::", 1)[0]) or "::" in arg):
            continue
        out.append(arg)
    return out


def run(args):
    code, items = collect(args)
    if code != 0:
        return code
    groups = group_items(items)
    if not groups:
        print("no tests collected", flush=True)
        return NO_TESTS
    options = options_only(args)
    results = []
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="florence-tests-") as tmp:
        for index, group in enumerate(groups, 1):
            xml = os.path.join(tmp, f"{index}.xml")
            print(f"\n===== [{index}/{len(groups)}] {group.name}: {len(group.node_ids)} tests, own process =====",
                  flush=True)
            t0 = time.monotonic()
            proc = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", f"--junitxml={xml}",
                                   *options, *group.node_ids], check=False)
            results.append((group, proc.returncode, time.monotonic() - t0, junit_counts(xml)))
            if proc.returncode != 0 and ({"-x", "--exitfirst"} & set(options)):
                break
    print("\n===== isolated run: one process per ROS test module =====")
    failures = []
    for group, rc, seconds, (tests, failed, skipped, names) in results:
        status = "ok" if rc == 0 else f"FAILED (exit {rc})"
        print(f"{status:16s} {seconds:7.1f} s  {tests:5d} tests  {failed:3d} failed  {skipped:3d} skipped  "
              f"{group.name}")
        failures.extend(names or ([] if rc == 0 else [f"{group.name} (exit {rc}, see its output)"]))
    total = sum(r[3][0] for r in results)
    print(f"{len(results)} processes, {total} tests, {len(failures)} failed, {time.monotonic() - start:.0f} s")
    for name in failures:
        print(f"FAILED {name}")
    return 0 if all(rc == 0 for _, rc, _, _ in results) else 1


def main():
    sys.exit(run(sys.argv[1:]))


if __name__ == "__main__":
    main()
