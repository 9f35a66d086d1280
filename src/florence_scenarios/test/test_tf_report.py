"""Unit tests of the ROS-free tf report used by the demo."""

import math

import numpy as np
import pytest
from florence_scenarios.tf_report import FrameLink, check_conventions, pose_in, render_tree

from florence_common.pose import quaternion_to_rpy

pytestmark = pytest.mark.unit

IDENTITY = (0.0, 0.0, 0.0, 1.0)
ROLL_PI = (1.0, 0.0, 0.0, 0.0)
# Optical frame in its camera frame: rpy (-pi/2, 0, -pi/2).
OPTICAL = (-0.5, 0.5, -0.5, 0.5)


def robot(laser_rotation=ROLL_PI):
    return {
        "base_link": FrameLink("base_footprint", (0.0, 0.0, 0.017), IDENTITY),
        "plate_1_link": FrameLink("base_link", (0.0, 0.0, 0.17), IDENTITY),
        "base_laser_link": FrameLink("plate_1_link", (0.06, 0.0, -0.02), laser_rotation),
        "base_laser_round_link": FrameLink("base_laser_link", (0.0, 0.0, 0.035), IDENTITY),
        "camera_link": FrameLink("base_link", (0.0, 0.0, 0.5), IDENTITY),
        "camera_depth_frame": FrameLink("camera_link", (0.0, -0.02, 0.0), IDENTITY),
        "camera_depth_optical_frame": FrameLink("camera_depth_frame", (0.0, 0.0, 0.0), OPTICAL),
        "camera_rgb_frame": FrameLink("camera_link", (0.0, -0.045, 0.0), IDENTITY),
        "camera_rgb_optical_frame": FrameLink("camera_rgb_frame", (0.0, 0.0, 0.0), OPTICAL),
    }


@pytest.mark.parametrize(
    "q, rpy",
    [
        (IDENTITY, (0.0, 0.0, 0.0)),
        (ROLL_PI, (math.pi, 0.0, 0.0)),
        ((0.0, 0.0, math.sin(0.3), math.cos(0.3)), (0.0, 0.0, 0.6)),
        (OPTICAL, (-math.pi / 2, 0.0, -math.pi / 2)),
    ],
)
def test_rpy_of_the_robot_frames(q, rpy):
    assert quaternion_to_rpy(q) == pytest.approx(rpy, abs=1e-9)


def test_pose_chains_translations_through_rotations():
    pose = pose_in(robot(), "base_link", "base_laser_round_link")
    # The window is 0.035 m along the inverted laser's z: downwards in base_link.
    assert pose[:3, 3] == pytest.approx([0.06, 0.0, 0.17 - 0.02 - 0.035])
    assert pose[:3, :3] @ np.array([0, 0, 1]) == pytest.approx([0, 0, -1])


def test_pose_of_unrelated_frame_raises():
    with pytest.raises(KeyError):
        pose_in(robot(), "base_link", "nowhere")


def test_conventions_pass_for_the_florence_robot():
    checks = check_conventions(robot())
    assert len(checks) == 4 and checks.passed, checks.markdown()


def test_conventions_catch_an_upright_laser():
    checks = check_conventions(robot(laser_rotation=IDENTITY))
    assert checks.failed() == ["laser upside down", "laser window below the laser body"]


def test_render_tree_lists_every_frame_with_height():
    text = render_tree(robot(), "base_footprint")
    assert text.splitlines()[0] == "base_footprint"
    for frame in robot():
        assert frame in text
    assert "base_laser_round_link" in text and "0.132 m above base_footprint" in text
