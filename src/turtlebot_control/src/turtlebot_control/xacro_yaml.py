"""Run xacro 1.13.3 (the ROS 1 release) with a ``load_yaml`` that works on PyYAML >= 6.

xacro 1.13.3 implements ``load_yaml`` with ``yaml.load(f)``, which PyYAML 6 (the
one Debian 12 ships) rejects for lack of a ``Loader``. This module swaps in a
``yaml.safe_load`` version and otherwise runs xacro unchanged, so ``$(find pkg)``
keeps its ROS 1 meaning. It does not import rospy.
"""

import sys

import xacro
import yaml


def load_yaml(filename):
    """``load_yaml()`` for xacro expressions: a relative name is taken from the including file."""
    path = xacro.abs_filename_spec(filename)
    saved = xacro.push_file(path)
    try:
        with open(path) as stream:
            return yaml.safe_load(stream)
    except (OSError, yaml.YAMLError) as exc:
        raise xacro.XacroException(f"cannot load YAML {path}: {exc}") from exc
    finally:
        xacro.restore_filestack(saved)
        xacro.all_includes.append(path)


def install():
    """Make ``load_yaml`` in xacro expressions use :func:`load_yaml`."""
    xacro.global_symbols["load_yaml"] = load_yaml


def expand(path, mappings=None):
    """Expand the xacro file ``path`` and return the URDF as a string."""
    install()
    doc = xacro.process_file(path, mappings=mappings or {})
    return doc.toprettyxml(indent="  ")


def main(argv=None):
    """Command line: exactly xacro's, e.g. ``xacro_yaml model.urdf.xacro name:=value``."""
    install()
    if argv is not None:
        sys.argv = [sys.argv[0], *argv]
    return xacro.main()
