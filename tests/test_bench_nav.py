"""bench/nav.py's ground-truth body clearance, against the apartment's furniture (no ROS).

The bench reports each leg's least gap between the robot's body and the world; it is what backs
"collisions 0" with a margin, so it must see the table top the laser passes under."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def nav():
    spec = importlib.util.spec_from_file_location("bench_nav", ROOT / "bench" / "nav.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def world_and_body(nav):
    from florence_sim.world import load_world

    return load_world(nav.WORLD).scene, nav.robot_body()


def track(*xy):
    return np.array([[0.0, x, y, 0.0, 0.0, 0.0] for x, y in xy])


def test_robot_body_is_the_create_up_to_the_kinect(world_and_body):
    _, (radius, height) = world_and_body
    assert 0.15 < radius < 0.2  # the Create's body
    assert height > 0.71  # taller than the dining table: its top stops the robot


def test_body_clearance_sees_the_table_top_and_not_only_its_legs(nav, world_and_body):
    scene, (radius, height) = world_and_body
    # the dining table: top x 2.8..4.0, y 3.4..4.2, 0.71 m up; legs at (3.4 +- 0.55, 3.8 +- 0.35)
    east = nav.body_clearance(scene, track((4.0 + radius + 0.10, 3.8)), radius, height)
    assert east == pytest.approx(0.10, abs=1e-6)  # from the top's edge; the legs are further off
    under = nav.body_clearance(scene, track((4.0 + radius + 0.10, 3.8), (3.4, 3.6)), radius, height)
    assert under < 0.0  # under the top: overlapping it
    assert nav.body_clearance(scene, track((4.0 + radius + 0.10, 3.8)), radius, 0.5) > 0.14  # a low robot: legs only
    assert nav.body_clearance(scene, np.empty((0, 6)), radius, height) is None


def test_clearance_spread_skips_legs_without_a_track(nav):
    spread = nav.clearance_spread([0.3, None, 0.1, 0.2])
    assert spread["min"] == pytest.approx(0.1) and spread["median"] == pytest.approx(0.2)
    assert nav.clearance_spread([None]) is None
