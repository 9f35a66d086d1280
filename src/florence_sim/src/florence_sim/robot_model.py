"""Sensor mounts and body dimensions read from the robot description (URDF), no ROS.

The simulator places its laser and camera where robot_state_publisher puts
their frames, so the numbers live in one place: turtlebot_control's xacro and
``robot_dimensions.yaml``. Poses are 4x4 homogeneous matrices (numpy).
"""

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from florence_common.pose import axis_angle_matrix, rpy_to_matrix

ROOT = "base_footprint"


def _xyz_rpy(origin):
    if origin is None:
        return [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    xyz = [float(v) for v in origin.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()]
    return xyz, rpy


def transform(xyz=(0, 0, 0), rpy=(0, 0, 0)):
    """4x4 matrix of a URDF origin (fixed-axis roll, pitch, yaw)."""
    m = np.eye(4)
    m[:3, :3] = rpy_to_matrix(rpy)
    m[:3, 3] = xyz
    return m


@dataclass
class Joint:
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float = -math.inf
    upper: float = math.inf


class RobotModel:
    """Kinematic tree of a URDF: pose of any link relative to ``base_footprint``."""

    def __init__(self, urdf_xml):
        root = ET.fromstring(urdf_xml)
        self.joints = {}
        self.parent_joint = {}
        for j in root.iter("joint"):
            xyz, rpy = _xyz_rpy(j.find("origin"))
            axis_el = j.find("axis")
            axis = np.array([float(v) for v in axis_el.get("xyz").split()]) if axis_el is not None else np.zeros(3)
            limit = j.find("limit")
            joint = Joint(j.get("name"), j.get("type"), j.find("parent").get("link"), j.find("child").get("link"),
                          transform(xyz, rpy), axis)
            if limit is not None:
                joint.lower = float(limit.get("lower", -math.inf))
                joint.upper = float(limit.get("upper", math.inf))
            self.joints[joint.name] = joint
            self.parent_joint[joint.child] = joint
        self.links = [link.get("name") for link in root.iter("link")]
        self._geometry = root

    @classmethod
    def from_xacro(cls, path=None, mappings=None):
        """Expand turtlebot_control's xacro (default: the Florence TurtleBot) and parse it."""
        from turtlebot_control import xacro_yaml

        if path is None:
            import rospkg

            path = rospkg.RosPack().get_path("turtlebot_control") + "/urdf/florence_turtlebot.urdf.xacro"
        return cls(xacro_yaml.expand(path, mappings))

    def pose(self, link, positions=None):
        """4x4 pose of ``link`` in ``base_footprint`` for joint ``positions`` {name: value [rad]}."""
        positions = positions or {}
        m = np.eye(4)
        while link != ROOT:
            if link not in self.parent_joint:
                raise KeyError(f"link {link!r} is not connected to {ROOT}")
            j = self.parent_joint[link]
            local = j.origin
            if j.kind in ("revolute", "continuous") and j.name in positions:
                local = local @ _axis_rotation(j.axis, positions[j.name])
            m = local @ m
            link = j.parent
        return m

    def cylinder_radius(self, link):
        """Radius [m] of the first cylinder in ``link``'s visual geometry."""
        for link_el in self._geometry.iter("link"):
            if link_el.get("name") == link:
                cyl = link_el.find("visual/geometry/cylinder")
                if cyl is not None:
                    return float(cyl.get("radius"))
        raise KeyError(f"link {link!r} has no cylinder geometry")

    def vertical_cylinders(self):
        """Upright cylinders of the robot's visuals (standoffs ...) as (link, x, y, radius, z0, z1)
        in base_footprint [m]."""
        out = []
        for link_el in self._geometry.iter("link"):
            name = link_el.get("name")
            for vis in link_el.iter("visual"):
                cyl = vis.find("geometry/cylinder")
                if cyl is None:
                    continue
                xyz, rpy = _xyz_rpy(vis.find("origin"))
                pose = self.pose(name) @ transform(xyz, rpy)
                if abs(abs(pose[2, 2]) - 1.0) > 1e-6:  # lying (wheels)
                    continue
                half = float(cyl.get("length")) / 2
                out.append((name, pose[0, 3], pose[1, 3], float(cyl.get("radius")), pose[2, 3] - half,
                            pose[2, 3] + half))
        return out

    def height(self):
        """Top of the robot [m] above the floor: the highest point of any link origin or box."""
        top = 0.0
        for link in self.links:
            with_link = self.pose(link) if link != ROOT else np.eye(4)
            top = max(top, with_link[2, 3])
        for link_el in self._geometry.iter("link"):
            for vis in link_el.iter("visual"):
                box = vis.find("geometry/box")
                if box is not None:
                    z = float(box.get("size").split()[2]) / 2
                    xyz, _ = _xyz_rpy(vis.find("origin"))
                    top = max(top, self.pose(link_el.get("name"))[2, 3] + xyz[2] + z)
        return top


def _axis_rotation(axis, angle):
    m = np.eye(4)
    m[:3, :3] = axis_angle_matrix(axis, angle)
    return m
