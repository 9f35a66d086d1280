"""Footprint parsing, padding and radii (costmap_2d's footprint rules)."""

import math

import numpy as np
import pytest
from move_base.footprint import (
    circumscribed_radius,
    inscribed_radius,
    pad_footprint,
    parse_footprint,
    transform_footprint,
)

pytestmark = pytest.mark.unit

SEED = [[-0.16, -0.16], [-0.16, 0.16], [0.19, 0.16], [0.24, 0.0], [0.19, -0.16]]


def test_seed_footprint_from_list_and_string():
    a = parse_footprint(SEED)
    b = parse_footprint(str(SEED))
    assert np.array_equal(a, b) and a.shape == (5, 2)


def test_padding_moves_each_coordinate_outwards():
    padded = pad_footprint(parse_footprint(SEED), 0.01)
    assert padded[0].tolist() == pytest.approx([-0.17, -0.17])
    assert padded[3].tolist() == pytest.approx([0.25, 0.0])  # y = 0 stays 0 (sign 0)


def test_a_costmap_keeps_the_body_beside_its_padded_footprint():
    from move_base.costmap_config import CostmapConfig

    cfg = {"footprint": SEED, "footprint_padding": 0.06, "observation_sources": ""}
    c = CostmapConfig.read(cfg.get)
    assert np.allclose(c.body, pad_footprint(np.array(SEED), 0.01))
    assert np.allclose(c.footprint, pad_footprint(np.array(SEED), 0.06))


def test_radii_of_the_padded_seed_footprint():
    padded = pad_footprint(parse_footprint(SEED), 0.01)
    assert inscribed_radius(padded) == pytest.approx(0.17)  # the back and the sides are 0.17 m away
    assert circumscribed_radius(padded) == pytest.approx(math.hypot(0.20, 0.17))  # the front corners


def test_inscribed_radius_of_a_slanted_edge():
    # a diamond: every edge lies on a line |x| + |y| = 1, 1/sqrt(2) from the origin; vertices are 1 away
    diamond = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    assert inscribed_radius(diamond) == pytest.approx(1.0 / math.sqrt(2.0))


def test_empty_footprint_is_a_circle_of_robot_radius():
    circle = parse_footprint("[]", robot_radius=0.2)
    assert np.hypot(circle[:, 0], circle[:, 1]) == pytest.approx(np.full(16, 0.2))


@pytest.mark.parametrize("bad", [[[0, 0], [1, 1]], [[0, 0, 0], [1, 1, 1], [2, 2, 2]], "[[0, 0], [1,", [[0, 0], [1, 0],
                                                                                                       [0, math.nan]]])
def test_malformed_footprints_are_refused(bad):
    with pytest.raises(ValueError, match="footprint"):
        parse_footprint(bad)


def test_transform_footprint():
    moved = transform_footprint([[1.0, 0.0], [0.0, 1.0]], 2.0, 3.0, math.pi / 2)
    assert moved.tolist() == [pytest.approx([2.0, 4.0]), pytest.approx([1.0, 3.0])]
