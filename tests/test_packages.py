"""The workspace holds every package of SPEC section 2 as a real catkin package."""

import importlib.util
import re
import subprocess
import xml.etree.ElementTree as ET

import pytest
import rospkg
from catkin_pkg.package import parse_package

from florence_harness import workspace

FLORENCE = ["turtlebot_control", "laser_filter", "laser_combinator", "velocity_filter", "florence_locator",
            "detect_users", "approach_me_map", "follow_me", "filter_user_tracker", "approach_me",
            "florence_bringup", "user_test"]
REPLACEMENTS = ["turtlebot_node", "hokuyo_node", "kinect_aux", "openni_camera", "pointcloud_to_laserscan",
                "user_tracker_ni", "map_server", "amcl", "move_base", "gmapping", "turtlebot_teleop",
                "turtlebot_calibration", "florence_sim"]
PACKAGES = workspace.packages()


def test_every_spec_package_exists():
    missing = sorted(set(FLORENCE + REPLACEMENTS) - set(PACKAGES))
    assert not missing, f"packages of SPEC section 2 missing from src/: {missing}"
    assert (workspace.root() / "maps").is_dir()


@pytest.mark.parametrize("name", sorted(PACKAGES))
def test_package_is_complete(name):
    path = PACKAGES[name]
    package = parse_package(str(path / "package.xml"))
    assert package.package_format == 2
    assert package.name == name
    assert (path / "CMakeLists.txt").is_file()
    assert re.search(rf"project\({name}\)", (path / "CMakeLists.txt").read_text())
    readme = path / "README.md"
    assert readme.is_file() and len(readme.read_text().strip()) > 40, "README must state the package's role"
    has_module = (path / "src" / name / "__init__.py").is_file()
    assert (path / "setup.py").is_file() == has_module, "setup.py exactly when there is a Python module"
    if has_module:
        assert "catkin_python_setup()" in (path / "CMakeLists.txt").read_text()


def _resolvable(dep, ros, debian, pinned):
    if dep in PACKAGES:
        return True
    # Debian ships some ROS packages (cv_bridge, diagnostic_updater, move_base_msgs) as
    # Python modules without a package.xml: importable is what a Python node needs.
    if importlib.util.find_spec(dep) is not None:
        return True
    if dep in pinned:  # pinned PyPI package (deps/requirements.txt)
        return True
    if dep.startswith("python3-"):
        return dep in debian
    try:
        ros.get_path(dep)
        return True
    except rospkg.ResourceNotFound:
        return False


@pytest.mark.parametrize("name", sorted(PACKAGES))
def test_dependencies_resolve(name):
    """Every declared dependency is a workspace package, an installed ROS package, a Debian package
    of deps/debian.txt or a pinned PyPI package of deps/requirements.txt."""
    package = parse_package(str(PACKAGES[name] / "package.xml"))
    ros = rospkg.RosPack()
    debian = set(workspace.listed("deps/debian.txt"))
    pinned = {line.split("==")[0] for line in workspace.listed("deps/requirements.txt")}
    deps = {d.name for d in package.buildtool_depends + package.build_depends + package.exec_depends}
    unresolved = sorted(d for d in deps if not _resolvable(d, ros, debian, pinned))
    assert not unresolved, f"{name} declares dependencies nothing provides: {unresolved}"


def test_interface_packages_declare_message_generation():
    for name, path in PACKAGES.items():
        has_interfaces = any((path / d).is_dir() for d in ("msg", "srv", "action"))
        if not has_interfaces:
            continue
        root = ET.parse(path / "package.xml").getroot()
        tags = {(e.tag, e.text) for e in root}
        assert ("build_depend", "message_generation") in tags, name
        assert ("exec_depend", "message_runtime") in tags, name


def test_debian_list_is_installed():
    """What tools/setup.sh installs is really on this machine (the lists do not drift)."""
    wanted = workspace.listed("deps/debian.txt")
    out = subprocess.run(["dpkg-query", "-W", "-f=${Package} ${Status}\n", *wanted],
                         capture_output=True, text=True, check=False).stdout
    installed = {line.split()[0] for line in out.splitlines() if line.endswith("install ok installed")}
    assert sorted(set(wanted) - installed) == []


@pytest.mark.parametrize("name", sorted(PACKAGES))
def test_executables_use_debian_python(name):
    for exe in workspace.executables(PACKAGES[name]):
        first = exe.read_text().splitlines()[0]
        assert exe.stat().st_mode & 0o111, f"{exe} is not executable"
        if "python" in first:
            assert first == "#!/usr/bin/python3", f"{exe}: shebang must be Debian's python, got {first!r}"
