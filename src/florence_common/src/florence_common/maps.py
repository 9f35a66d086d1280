"""Where the workspace's maps are: the ``maps/`` folder at the repository root.

``devel/setup.bash`` exports ``FLORENCE_MAPS`` (florence_common's catkin environment
hook), so launch files say ``$(env FLORENCE_MAPS)/apartment/apartment.yaml`` and code
calls :func:`maps_dir` or :func:`map_file`; nothing counts ``../..`` from a package.
"""

import os
from pathlib import Path

ENV = "FLORENCE_MAPS"


def maps_dir():
    """The maps folder (Path). Raises RuntimeError when the workspace is not sourced."""
    path = os.environ.get(ENV)
    if not path:
        raise RuntimeError(f"{ENV} is not set: source the workspace's devel/setup.bash first")
    return Path(path)


def map_file(*parts):
    """A file below the maps folder, e.g. ``map_file("apartment", "rooms.yaml")`` (Path)."""
    return maps_dir().joinpath(*parts)
