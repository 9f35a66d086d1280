"""Render a tf tree as text and check the Florence robot's frame conventions.

ROS-free: frames are given as a mapping ``child -> FrameLink`` (parent name,
translation [m] and quaternion (x, y, z, w) of the child in the parent).
"""

from dataclasses import dataclass

import numpy as np

from florence_common.pose import quaternion_to_rpy, transform_matrix
from florence_scenarios.checks import Checks


@dataclass(frozen=True)
class FrameLink:
    parent: str
    translation: tuple  # (x, y, z) [m] of the child's origin in the parent frame
    rotation: tuple  # (x, y, z, w) unit quaternion of the child's axes in the parent frame


def pose_in(frames, root, frame):
    """4x4 homogeneous pose of ``frame`` in ``root`` by chaining ``frames``.

    Raises KeyError when ``frame`` does not descend from ``root``.
    """
    chain = []
    current = frame
    while current != root:
        link = frames[current]
        chain.append(link)
        current = link.parent
    pose = np.eye(4)
    for link in reversed(chain):
        pose = pose @ transform_matrix(link.translation, link.rotation)
    return pose


def render_tree(frames, root):
    """Indented text of the tree below ``root``: each frame with its pose in its parent
    and its height above ``root``."""
    children = {}
    for child, link in frames.items():
        children.setdefault(link.parent, []).append(child)
    lines = [root]

    def walk(parent, depth):
        for child in sorted(children.get(parent, [])):
            link = frames[child]
            roll, pitch, yaw = quaternion_to_rpy(link.rotation)
            height = pose_in(frames, root, child)[2, 3]
            x, y, z = link.translation
            lines.append(
                f"{'  ' * depth}{child}: xyz=({x:+.4f}, {y:+.4f}, {z:+.4f}) m"
                f" rpy=({roll:+.4f}, {pitch:+.4f}, {yaw:+.4f}) rad, {height:.3f} m above {root}"
            )
            walk(child, depth + 1)

    walk(root, 1)
    return "\n".join(lines)


def check_conventions(frames, base="base_link"):
    """The frame conventions the Florence nodes rely on (:class:`Checks`)."""
    rows = Checks()

    def axis_in_base(frame, axis):
        return pose_in(frames, base, frame)[:3, :3] @ np.asarray(axis, dtype=float)

    try:
        z = axis_in_base("base_laser_link", (0, 0, 1))
        y = axis_in_base("base_laser_link", (0, 1, 0))
        upside_down = bool(z[2] < -0.999 and y[1] < -0.999)
        rows.add("laser upside down", upside_down, f"laser z axis in {base} = {np.round(z, 4).tolist()}")
        window_z = pose_in(frames, base, "base_laser_round_link")[2, 3]
        below = bool(window_z < pose_in(frames, base, "base_laser_link")[2, 3])
        rows.add("laser window below the laser body", below, "base_laser_round_link lower than base_laser_link")
    except KeyError as exc:
        rows.add("laser frames present", False, f"missing {exc}")
    for optical in ("camera_depth_optical_frame", "camera_rgb_optical_frame"):
        try:
            z = axis_in_base(optical, (0, 0, 1))
            detail = f"optical z axis in {base} = {np.round(z, 4).tolist()}"
            rows.add(f"{optical} looks forward", bool(z[0] > 0.99), detail)
        except KeyError as exc:
            rows.add(f"{optical} present", False, f"missing {exc}")
    return rows
