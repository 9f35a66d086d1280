"""What ships, read as the product reads it, for the offline evaluations (no ROS): the ``<param>`` values a
launch file gives a node, and the robot description's file."""

import xml.etree.ElementTree as ET
from pathlib import Path

import rospkg
import yaml

TURTLEBOT_CONTROL = Path(rospkg.RosPack().get_path("turtlebot_control"))
XACRO = TURTLEBOT_CONTROL / "urdf" / "florence_turtlebot.urdf.xacro"


def launch_params(path, node, args=None):
    """{name: value} of the ``<param>``s of ``node`` in a launch file; ``$(arg x)`` from ``args`` or the arg's
    default. Values are typed as roslaunch types them (YAML scalars: true, 0.1, 15000 ...)."""
    root = ET.parse(path).getroot()
    argv = {a.get("name"): a.get("default", a.get("value")) for a in root.iter("arg")}
    argv.update({k: str(v) for k, v in (args or {}).items()})
    out = {}
    for n in root.iter("node"):
        if n.get("name") != node:
            continue
        for p in n.iter("param"):
            text = p.get("value")
            for name, value in argv.items():
                text = text.replace(f"$(arg {name})", str(value))
            out[p.get("name")] = yaml.safe_load(text) if p.get("type") != "str" else text
    return out


