"""The node's parameter table covers every setting of the cores, with the cores' defaults."""

import dataclasses

import pytest
from user_tracker_ni.params import GROUPS, PARAMS, split

pytestmark = pytest.mark.unit


@pytest.mark.parametrize("group", sorted(GROUPS))
def test_every_core_setting_is_a_parameter_with_the_same_default(group):
    table = {p.name: p for p in PARAMS}
    for field in dataclasses.fields(GROUPS[group]):
        name = f"{group}/{field.name}"
        assert name in table, f"~{name} is missing from the parameter table"
        assert table[name].default == field.default, name


def test_defaults_split_into_the_cores_defaults():
    values = PARAMS.read(lambda name, default: default)
    node, pipeline, static = split(values)
    assert node["fixed_frame"] == "odom" and node["map_frame"] == "map"
    assert pipeline.depth == GROUPS["kinect"]() and pipeline.tracker == GROUPS["tracker"]()
    assert static == GROUPS["map"]()


def test_a_value_reaches_its_core():
    values = PARAMS.read({"tracker/timeout": 2.5, "laser/min_width": 0.07}.get)
    _, pipeline, _ = split(values)
    assert pipeline.tracker.timeout == 2.5 and pipeline.legs.min_width == 0.07
