"""Facts about this catkin workspace, for tests and tools (no rospy).

The workspace root is found from ``FLORENCE_WS`` or by walking up from this file
to the directory holding ``.catkin_workspace``.
"""

import os
from pathlib import Path


def root():
    env = os.environ.get("FLORENCE_WS")
    if env:
        return Path(env).resolve()
    for parent in Path(__file__).resolve().parents:
        if (parent / ".catkin_workspace").exists():
            return parent
    raise RuntimeError("cannot find the workspace root (no .catkin_workspace above this file); set FLORENCE_WS")


def packages():
    """``{name: path}`` of every catkin package under ``src/``."""
    found = {}
    for package_xml in sorted((root() / "src").glob("*/package.xml")):
        found[package_xml.parent.name] = package_xml.parent
    return found


def launch_files():
    """Every launch file of the workspace: ``*.launch`` and ``*.launch.xml`` under ``src/``."""
    src = root() / "src"
    return sorted({*src.glob("*/**/*.launch"), *src.glob("*/**/*.launch.xml")})


def listed(path):
    """Non-comment, non-blank lines of a dependency list such as ``deps/debian.txt``."""
    items = []
    for raw in (root() / path).read_text().splitlines():
        line = raw.split("#", 1)[0].strip()
        if line:
            items.append(line)
    return items


def executables(package_dir):
    """Executables a package ships in ``nodes/`` and ``scripts/``."""
    out = []
    for sub in ("nodes", "scripts"):
        d = Path(package_dir) / sub
        if d.is_dir():
            out += sorted(p for p in d.iterdir() if p.is_file())
    return out
