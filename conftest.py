"""Workspace-wide pytest set-up: the ROS fixtures of florence_harness.

Run the tests through `make test` (or after `source devel/setup.bash`), with
/usr/bin/python3, so the generated messages and Debian's ROS modules import.
"""

try:
    import florence_harness.pytest_plugin  # noqa: F401
except ImportError as exc:  # pragma: no cover - environment problem, not a test failure
    raise SystemExit(
        f"cannot import florence_harness ({exc}); build and source the workspace first: "
        "`make build && source devel/setup.bash`, and use /usr/bin/python3 -m pytest"
    ) from exc

pytest_plugins = ["florence_harness.pytest_plugin"]
