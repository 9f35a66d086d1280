"""Workspace-wide pytest set-up: the ROS fixtures of florence_harness.

Run the tests through `make test` (or after `source devel/setup.bash`), with
/usr/bin/python3, so the generated messages and Debian's ROS modules import.
"""

import importlib.util

if importlib.util.find_spec("florence_harness") is None:  # pragma: no cover - environment problem
    raise SystemExit(
        "cannot import florence_harness: build and source the workspace first "
        "(`make build && source devel/setup.bash`) and use /usr/bin/python3 -m pytest"
    )

pytest_plugins = ["florence_harness.pytest_plugin"]
