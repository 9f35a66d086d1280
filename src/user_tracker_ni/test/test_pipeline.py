"""The pipeline on synthetic Kinect frames: a seated person the robot drives up to is kept close up
by her colours, where neither detector sees her."""

import numpy as np
import pytest
from user_tracker_ni.depth_people import DepthParams
from user_tracker_ni.pipeline import Pipeline, PipelineParams

from florence_common import pose
from florence_common.camera import Camera
from florence_harness import kinect_scenes as scenes

pytestmark = pytest.mark.unit

CAMERA = Camera.from_k(scenes.K, scenes.WIDTH, scenes.HEIGHT)
RED, BLUE = (200, 30, 30), (30, 60, 200)
SEAT = (3.0, 0.1)  # [m] in the fixed frame


def drive_up(pipeline, shirt_near=RED, rate=10.0):
    """The robot at x = 0 sees her seated 3 m ahead for 1 s, then stands 2.1 m further on (her 0.9 m
    ahead) for 3 s; returns the published tracks' positions after each close frame."""
    out = []
    for k in range(int(4 * rate)):
        t = k / rate
        robot_x = 0.0 if t < 1.0 else 2.1
        shirt = RED if t < 1.0 else shirt_near
        depth, colour = scenes.render(scenes.sitting(SEAT[0] - robot_x, SEAT[1], shirt), noise=0.0016, seed=k)
        base = pose.transform_matrix((robot_x, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        pipeline.on_depth(t, depth, CAMERA, scenes.CAMERA_POSE, base, colour)
        if t >= 1.0:
            out.append([tr.output(0.3) for tr in pipeline.published()])
    return out


def test_a_seated_person_the_robot_comes_close_to_stays_tracked_in_place():
    pipeline = Pipeline()
    frames = drive_up(pipeline)
    assert all(len(f) == 1 for f in frames), [len(f) for f in frames]
    assert np.allclose(frames[-1][0], SEAT, atol=0.1), frames[-1]
    assert pipeline.counts["close up"] >= 25


def test_without_close_sightings_she_is_lost_and_another_shirt_does_not_keep_her():
    off = Pipeline(PipelineParams(depth=DepthParams(close_range=0.0)))
    assert drive_up(off)[-1] == []
    swapped = Pipeline()
    assert drive_up(swapped, shirt_near=BLUE)[-1] == []
    assert swapped.counts["close up"] == 0
