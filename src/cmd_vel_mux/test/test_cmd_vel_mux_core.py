"""Priority and timeout rules of the multiplexer, table-driven on the ROS-free core."""

import pytest
from cmd_vel_mux.mux import IDLE, MuxInput, PriorityMux, parse_inputs

pytestmark = pytest.mark.unit

INPUTS = [
    MuxInput("teleop", "input/teleop", 10, 0.5),
    MuxInput("follow_me", "input/follow_me", 5, 0.5),
    MuxInput("approach_me", "input/approach_me", 5, 0.5),
    MuxInput("move_base", "input/move_base", 1, 1.0),
]

# Each row: a script of (time [s], event) with event an input name (a message) or "tick";
# expected: what each message returned (forwarded?) / each tick returned (went idle?),
# and the active input after the event.
SCENARIOS = {
    "first message takes an idle mux": [(0.0, "move_base", True, "move_base")],
    "higher priority takes over": [
        (0.0, "move_base", True, "move_base"), (0.1, "teleop", True, "teleop"),
        (0.2, "move_base", False, "teleop"), (0.3, "teleop", True, "teleop")],
    "lower priority cannot take over": [
        (0.0, "follow_me", True, "follow_me"), (0.1, "move_base", False, "follow_me")],
    "equal priority cannot take over": [
        (0.0, "follow_me", True, "follow_me"), (0.1, "approach_me", False, "follow_me")],
    "hand-back to the fresh lower input after the timeout": [
        (0.0, "move_base", True, "move_base"), (0.1, "teleop", True, "teleop"),
        (0.5, "move_base", False, "teleop"), (0.55, "tick", False, "teleop"),
        (0.61, "tick", False, "move_base"), (0.7, "move_base", True, "move_base")],
    "hand-back picks the highest fresh input": [
        (0.0, "move_base", True, "move_base"), (0.05, "follow_me", True, "follow_me"),
        (0.1, "teleop", True, "teleop"), (0.4, "move_base", False, "teleop"),
        (0.45, "follow_me", False, "teleop"), (0.61, "tick", False, "follow_me")],
    "silence everywhere goes idle once": [
        (0.0, "teleop", True, "teleop"), (0.49, "tick", False, "teleop"),
        (0.5, "tick", True, None), (0.6, "tick", False, None)],
    "a stale lower input is not handed control": [
        (0.0, "move_base", True, "move_base"), (0.5, "teleop", True, "teleop"),
        (1.0, "tick", True, None), (1.1, "move_base", True, "move_base")],
}


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scenario(name):
    mux = PriorityMux(INPUTS)
    for now, event, expected, active in SCENARIOS[name]:
        result = mux.update(now) if event == "tick" else mux.offer(event, now)
        assert result is expected, f"t={now} {event}"
        assert mux.active == active, f"t={now} {event}"
    assert mux.active_name == (mux.active or IDLE)


GOOD = {"name": "teleop", "topic": "input/teleop", "priority": 10, "timeout": 0.5}


@pytest.mark.parametrize(
    "config, message",
    [
        ([], "non-empty list"),
        ("teleop", "non-empty list"),
        ([42], "mapping"),
        ([{"name": "a", "topic": "t", "priority": 1}], "timeout"),
        ([dict(GOOD, name="")], "name"),
        ([dict(GOOD, name=IDLE)], "name"),
        ([dict(GOOD, priority=1.5)], "priority"),
        ([dict(GOOD, priority=True)], "priority"),
        ([dict(GOOD, timeout=0)], "timeout"),
        ([dict(GOOD, timeout=float("nan"))], "timeout"),
        ([dict(GOOD, topic="")], "topic"),
        ([GOOD, dict(GOOD, topic="x")], "names must be unique"),
        ([GOOD, dict(GOOD, name="x")], "topics must be unique"),
    ],
)
def test_bad_configuration_is_refused(config, message):
    with pytest.raises(ValueError, match=message):
        parse_inputs(config)


def test_shipped_configuration_orders_teleop_enablers_move_base():
    from pathlib import Path

    import yaml

    path = Path(__file__).resolve().parents[1] / "config" / "cmd_vel_mux.yaml"
    inputs = {m.name: m for m in parse_inputs(yaml.safe_load(path.read_text())["inputs"])}
    assert inputs["teleop"].priority > inputs["follow_me"].priority == inputs["approach_me"].priority
    assert inputs["approach_me"].priority > inputs["move_base"].priority
