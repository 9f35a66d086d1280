"""The workspace holds every package of SPEC section 2 as a real catkin package."""

import importlib
import importlib.util
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
import rospkg
from catkin_pkg.package import parse_package

from florence_harness import workspace

pytestmark = pytest.mark.unit

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
    assert (path / "README.md").is_file(), f"{name} has no README.md"
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


def test_build_order_has_no_cycle():
    """catkin orders the packages by every declared dependency, test_depend included: a cycle
    fails a clean build's cmake step (an incremental build keeps its old order and hides it)."""
    from catkin_pkg.topological_order import topological_order_packages

    packages = {str(path): parse_package(str(path / "package.xml")) for path in PACKAGES.values()}
    cyclic = sorted(name for path, package in topological_order_packages(packages)
                    if path is None for name in [package.name])
    assert not cyclic, f"catkin sees a dependency cycle through {cyclic}"


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


# --- what a package's code imports, its package.xml declares ---------------------------------------------------
# Python modules that Debian ships under another package name (deps/debian.txt).
DEBIAN_MODULES = {"numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml", "cv2": "python3-opencv",
                  "serial": "python3-serial", "numba": "python3-numba", "PIL": "python3-pil",
                  "matplotlib": "python3-matplotlib", "skimage": "python3-skimage", "pytest": "python3-pytest",
                  "usb": "python3-usb", "sklearn": "python3-sklearn"}
# ROS Python modules whose ROS package has another name
ROS_MODULES = {"tf2_geometry_msgs": "tf2_geometry_msgs", "roslib": "roslib", "rosunit": "rosunit",
               "catkin_pkg": "python3-catkin-pkg", "rospkg": "rospkg", "xacro": "xacro"}
PINNED = {line.split("==")[0] for line in workspace.listed("deps/requirements.txt")}


def _imports(paths):
    """Top-level module names imported by the Python files ``paths`` (absolute imports)."""
    import ast

    found = {}
    for file in paths:
        try:
            tree = ast.parse(file.read_text(), str(file))
        except (SyntaxError, UnicodeDecodeError):
            continue  # not Python (a shell script among the executables)
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            for n in names:
                found.setdefault(n.split(".")[0], file)
    return found


def _python_files(path, kind):
    if kind == "runtime":
        files = list((path / "src").rglob("*.py")) if (path / "src").is_dir() else []
        return files + [f for f in workspace.executables(path)]
    return list((path / "test").rglob("*.py")) if (path / "test").is_dir() else []


def _package_of(module):
    if module in DEBIAN_MODULES:
        return DEBIAN_MODULES[module]
    return ROS_MODULES.get(module, module)


@pytest.mark.parametrize("kind", ["runtime", "test"])
@pytest.mark.parametrize("name", sorted(PACKAGES))
def test_package_xml_declares_what_the_code_imports(name, kind):
    """Runtime code's imports are exec_depends; test code's are test_depends or exec_depends. Only tests
    may use the test harness."""
    path = PACKAGES[name]
    package = parse_package(str(path / "package.xml"))
    declared = {d.name for d in package.exec_depends + package.build_export_depends}
    if kind == "test":
        declared |= {d.name for d in package.test_depends}
    missing = {}
    for module, file in _imports(_python_files(path, kind)).items():
        if module in sys.stdlib_module_names or module == name or module in PINNED:
            continue
        dep = _package_of(module)
        if dep not in declared:
            missing[dep] = str(file.relative_to(path))
    assert not missing, f"{name}: imported but not declared in package.xml ({kind}): {missing}"
    if kind == "runtime":
        assert "florence_harness" not in {d.name for d in package.exec_depends} or name == "florence_harness", \
            f"{name}: runtime code must not depend on the test harness"


# --- each README documents its package's ROS interface -------------------------------------------------------------
def _param_tables(name):
    """``{module.TABLE: ParamTable}`` defined at module level in the package's Python modules."""
    from florence_common.params import ParamTable

    tables, seen = {}, set()
    src = PACKAGES[name] / "src" / name
    for file in sorted(src.glob("*.py")) if src.is_dir() else []:
        module_name = f"{name}.{file.stem}" if file.stem != "__init__" else name
        module = importlib.import_module(module_name)
        for attr, value in vars(module).items():
            if isinstance(value, ParamTable) and id(value) not in seen:  # imported tables count once
                seen.add(id(value))
                tables[f"{module_name}.{attr}"] = value
    return tables


def _normalise(text):
    return "\n".join(" ".join(line.split()) for line in text.strip().splitlines())


@pytest.mark.parametrize("name", sorted(PACKAGES))
def test_readme_documents_the_ros_interface(name):
    """Every README has a '## ROS interface' section; it names every executable the package ships and holds
    the rendered table of every parameter table the package's code defines (tools/params_doc.py prints it)."""
    path = PACKAGES[name]
    readme = (path / "README.md").read_text()
    assert "\n## ROS interface\n" in readme, f"{name}/README.md has no '## ROS interface' section"
    for exe in workspace.executables(path):
        assert f"`{exe.name}`" in readme, f"{name}/README.md does not name its executable {exe.name}"
    text = _normalise(readme)
    for where, table in _param_tables(name).items():
        rows = _normalise(table.markdown()).splitlines()[2:]  # a table may be rendered whole or in parts
        missing = [row.split(" | ")[0].strip("| `") for row in rows if row not in text]
        assert not missing, (f"{name}/README.md lacks the rows {missing} of {where}'s table "
                             f"(tools/params_doc.py {where.rsplit('.', 1)[0]} {where.rsplit('.', 1)[1]})")
