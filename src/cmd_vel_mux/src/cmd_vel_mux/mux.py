"""Priority arbitration between velocity command sources, ROS-free.

Semantics (those of yocs_cmd_vel_mux, which ROS users know from the TurtleBot 2 stack,
plus an explicit stop when control lapses):

- An input is *fresh* while its last message is younger than its ``timeout``.
- A message is forwarded if its input is the active one, or if there is no active input,
  or if its input has a strictly higher priority than the active one (it takes over).
  Messages of lower or equal priority inputs are dropped while another input is active.
- When the active input goes silent for its timeout, control goes to the highest-priority
  input that is still fresh (its next message is forwarded); if none is fresh the mux is
  idle and reports that once, so the node can send a single zero command (the robot stops
  at the velocity filter's deceleration instead of coasting on the last command until
  the filter's own timeout).
"""

import math
from dataclasses import dataclass

IDLE = "idle"


@dataclass(frozen=True)
class MuxInput:
    name: str  # reported on ~active
    topic: str  # subscribed topic (relative names resolve in the node's private namespace)
    priority: int  # larger wins
    timeout: float  # [s] silence after which the input lets go


def parse_inputs(config):
    """Validate the ``inputs`` list of the YAML configuration; return MuxInput objects.

    Raises ValueError naming the offending entry.
    """
    if not isinstance(config, list) or not config:
        raise ValueError(f"inputs must be a non-empty list of {{name, topic, priority, timeout}}, got {config!r}")
    inputs = []
    for i, entry in enumerate(config):
        if not isinstance(entry, dict):
            raise ValueError(f"inputs[{i}] must be a mapping, got {entry!r}")
        missing = sorted({"name", "topic", "priority", "timeout"} - set(entry))
        if missing:
            raise ValueError(f"inputs[{i}] lacks {missing}")
        name, topic, priority, timeout = entry["name"], entry["topic"], entry["priority"], entry["timeout"]
        if not isinstance(name, str) or not name or name == IDLE:
            raise ValueError(f"inputs[{i}].name must be a non-empty string other than {IDLE!r}, got {name!r}")
        if not isinstance(topic, str) or not topic:
            raise ValueError(f"inputs[{i}] ({name}): topic must be a non-empty string")
        if isinstance(priority, bool) or not isinstance(priority, int):
            raise ValueError(f"inputs[{i}] ({name}): priority must be an integer, got {priority!r}")
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not (
                math.isfinite(timeout) and timeout > 0):
            raise ValueError(f"inputs[{i}] ({name}): timeout must be a number > 0 [s], got {timeout!r}")
        inputs.append(MuxInput(name, topic, priority, float(timeout)))
    for attr in ("name", "topic"):
        values = [getattr(m, attr) for m in inputs]
        dupes = sorted({v for v in values if values.count(v) > 1})
        if dupes:
            raise ValueError(f"input {attr}s must be unique, repeated: {dupes}")
    return inputs


class PriorityMux:
    """Which input may drive the robot. ``now`` is time in seconds (ROS time in the node)."""

    def __init__(self, inputs):
        self.inputs = {m.name: m for m in inputs}
        self.active = None  # name of the input in control, None when idle
        self._last = {}  # name -> [s] time of its last message

    def fresh(self, name, now):
        last = self._last.get(name)
        return last is not None and now - last < self.inputs[name].timeout

    def offer(self, name, now):
        """A message arrived on input ``name``; return True if it is to be forwarded."""
        self._last[name] = now
        active = self.active
        if active is None or active == name or self.inputs[name].priority > self.inputs[active].priority:
            self.active = name
            return True
        return False

    def update(self, now):
        """Expire a silent active input; return True exactly when the mux has just gone idle."""
        if self.active is None or self.fresh(self.active, now):
            return False
        candidates = [m for m in self.inputs.values() if self.fresh(m.name, now)]
        if candidates:
            self.active = max(candidates, key=lambda m: m.priority).name
            return False
        self.active = None
        return True

    @property
    def active_name(self):
        return self.active or IDLE
