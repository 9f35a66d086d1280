"""The depth detector on synthetic images: standing and sitting people, walls, clutter, two people
side by side, colour signatures, bad input."""

import numpy as np
import pytest
from user_tracker_ni.depth_people import Camera, DepthParams, detect

from florence_harness import kinect_scenes as scenes
from user_tracker_ni import reid

pytestmark = pytest.mark.unit

CAMERA = Camera(scenes.K, scenes.WIDTH, scenes.HEIGHT)
P = DepthParams().validate()
RED, BLUE = (200, 30, 30), (30, 60, 200)


def run(cylinders=(), walls=(), noise=0.0016, rgb=True):
    depth, colour = scenes.render(cylinders, walls, noise=noise)
    return detect(depth, CAMERA, scenes.CAMERA_POSE, P, colour if rgb else None)


@pytest.mark.parametrize("distance", [1.5, 2.5, 3.5])
def test_a_standing_person_is_found_at_their_centre(distance):
    people, _ = run(scenes.standing(distance, 0.3, RED))
    assert len(people) == 1
    (p,) = people
    assert (p.x, p.y) == pytest.approx((distance, 0.3), abs=0.08)
    assert p.posture == ("standing" if distance > 3.0 else "unknown")  # the head is in view beyond ~2.9 m
    assert p.signature is not None


def test_a_sitting_person_is_found_and_seen_sitting():
    people, _ = run(scenes.sitting(2.5, -0.2, BLUE))
    assert len(people) == 1
    assert (people[0].x, people[0].y) == pytest.approx((2.5, -0.2), abs=0.08)
    assert people[0].posture == "sitting"


def test_two_people_side_by_side_are_two():
    people, _ = run(scenes.standing(2.5, 0.45, RED) + scenes.standing(2.5, -0.45, BLUE))
    assert sorted(round(p.y, 1) for p in people) == pytest.approx([-0.45, 0.45], abs=0.1)
    red = min(people, key=lambda p: abs(p.y - 0.45))
    blue = min(people, key=lambda p: abs(p.y + 0.45))
    assert reid.distance(red.signature, blue.signature) > 0.8


def test_a_wall_is_no_person():
    people, rejected = run(walls=[(3.0, -3.0, 3.0, 3.0, (230, 230, 220)), (1.5, 1.0, 4.0, 1.0, (230, 230, 220))])
    assert people == []
    assert sum(rejected.values()) >= 1


def test_a_person_in_front_of_a_wall_is_found():
    people, _ = run(scenes.standing(2.2, 0.0, RED), walls=[(3.0, -3.0, 3.0, 3.0, (230, 230, 220))])
    assert len(people) == 1 and people[0].x == pytest.approx(2.2, abs=0.08)


@pytest.mark.parametrize("clutter", [scenes.coat_stand, scenes.floor_lamp, scenes.tall_plant])
def test_person_sized_clutter_is_no_person(clutter):
    people, rejected = run(clutter(2.5, 0.2))
    assert people == [], rejected


def test_clutter_beside_a_person_leaves_the_person():
    people, _ = run(scenes.floor_lamp(2.5, 0.8) + scenes.standing(2.5, -0.1, RED))
    assert len(people) == 1 and people[0].y == pytest.approx(-0.1, abs=0.08)


def test_same_shirt_same_signature_different_shirt_different():
    a = run(scenes.standing(2.0, 0.2, RED))[0][0].signature
    b = run(scenes.standing(3.2, -0.5, RED))[0][0].signature
    c = run(scenes.standing(2.0, 0.2, BLUE))[0][0].signature
    assert reid.distance(a, b) < 0.3
    assert reid.distance(a, c) > 0.8


def test_without_colour_there_is_no_signature():
    people, _ = run(scenes.standing(2.0, 0.0, RED), rgb=False)
    assert len(people) == 1 and people[0].signature is None


def test_bad_input():
    nan = np.full((scenes.HEIGHT, scenes.WIDTH), np.nan, np.float32)
    assert detect(nan, CAMERA, scenes.CAMERA_POSE, P) == ([], {})
    with pytest.raises(ValueError, match="does not match"):
        detect(np.zeros((10, 10), np.float32), CAMERA, scenes.CAMERA_POSE, P)
    with pytest.raises(ValueError, match="intrinsics"):
        Camera([0.0] * 9, 160, 120)


def test_millimetre_images_work_once_converted():
    """16UC1 images (mm) are converted by the node; zeros mean no return and are ignored."""
    depth, colour = scenes.render(scenes.standing(2.0, 0.0, RED))
    mm = np.nan_to_num(depth * 1000.0, nan=0.0).astype(np.uint16)
    people, _ = detect(mm.astype(np.float32) / 1000.0, CAMERA, scenes.CAMERA_POSE, P, colour)
    assert len(people) == 1
