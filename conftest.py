"""Workspace-wide pytest set-up: the ROS fixtures of florence_harness, and the test tiers.

Run the tests through `make test` (or after `source devel/setup.bash`), with
/usr/bin/python3, so the generated messages and Debian's ROS modules import.

Every test belongs to exactly one tier (pyproject.toml lists them): unit, ros, protocol or
scenario, usually by its module's `pytestmark = pytest.mark.<tier>`, in a module of mixed
tiers by each test's own mark. A test with no tier or two is refused at collection. `slow`
marks the long tests of any tier. One tier: `make test PYTEST_ARGS="-m unit"`.
"""

import importlib.util

import pytest

if importlib.util.find_spec("florence_harness") is None:  # pragma: no cover - environment problem
    raise SystemExit(
        "cannot import florence_harness: build and source the workspace first "
        "(`make build && source devel/setup.bash`) and use /usr/bin/python3 -m pytest"
    )

pytest_plugins = ["florence_harness.pytest_plugin"]

TIERS = ("unit", "ros", "protocol", "scenario")


def pytest_collection_modifyitems(config, items):
    """Refuse a test with no tier, or with two (a module's and its own)."""
    bad = []
    for item in items:
        tiers = {m.name for m in item.iter_markers() if m.name in TIERS}
        if len(tiers) != 1:
            bad.append(f"{item.nodeid}: {', '.join(sorted(tiers)) or 'no tier'}")
    if bad:
        raise pytest.UsageError(f"every test needs exactly one tier marker of {', '.join(TIERS)}:\n  "
                                + "\n  ".join(bad))
