"""dynamic_reconfigure from a florence_common.params.ParamTable: one declaration of a node's tunable
gains serves the .cfg (the catkin generate step), the node's start-up values, the README's table and
the live retuning.

In the package's ``cfg/Gains.cfg`` (executable, ``#!/usr/bin/python3``), run by catkin's
``generate_dynamic_reconfigure_options``::

    from florence_common_ros.reconfigure import generate
    from follow_me.law import GAINS
    generate("follow_me", "follow_me_node", "FollowMe", GAINS)

In the node::

    self.gains = read_params(GAINS)                       # validated start-up values (~k_distance ...)
    self.reconfigure = Reconfigure(FollowMeConfig, GAINS, self.on_gains)

``on_gains(params)`` receives every accepted change as validated Params. A change that the table
refuses (dynamic_reconfigure only clamps to min and max) is reported and the previous values stay.
"""

import rospy

_TYPES = {float: "double", int: "int", bool: "bool", str: "str"}


def _bounds(param):
    """(min, max) for dynamic_reconfigure of a numeric parameter (its own bounds, inclusive)."""
    low = param.ge if param.ge is not None else param.gt
    high = param.le if param.le is not None else param.lt
    return low, high


def generate(package, node_name, config_name, table):
    """The body of a .cfg file: add every parameter of ``table`` and generate (exits the script)."""
    from dynamic_reconfigure.parameter_generator_catkin import ParameterGenerator

    gen = ParameterGenerator()
    for p in table:
        if p.type not in _TYPES:
            raise TypeError(f"{p.name}: dynamic_reconfigure has no type for {p.type!r}")
        doc = f"{p.doc} [{p.unit}]" if p.unit else p.doc
        if p.type in (float, int):
            low, high = _bounds(p)
            gen.add(p.name, _TYPES[p.type], 0, doc, p.default, low, high)
        else:
            gen.add(p.name, _TYPES[p.type], 0, doc, p.default)
    raise SystemExit(gen.generate(package, node_name, config_name))


class Reconfigure:
    """A dynamic_reconfigure server over ``table`` (its names) in the node's private namespace."""

    def __init__(self, config_type, table, on_change, log_prefix=""):
        from dynamic_reconfigure.server import Server

        self.table = table
        self.on_change = on_change
        self.log_prefix = log_prefix
        self.values = None
        self.server = Server(config_type, self._callback)

    def _callback(self, config, _level):
        wanted = {p.name: config[p.name] for p in self.table if p.name in config}
        try:
            values = self.table.validate(wanted)
        except ValueError as exc:
            rospy.logwarn(self.log_prefix + "reconfigure refused: %s; keeping the previous values", exc)
            if self.values is None:
                return config
            for name in wanted:
                config[name] = self.values[name]
            return config
        if values != self.values:
            if self.values is not None:
                changes = ", ".join(f"{k} {self.values[k]} -> {v}" for k, v in values.items() if self.values[k] != v)
                rospy.loginfo(self.log_prefix + "reconfigured: %s", changes)
            self.values = values
            self.on_change(values)
        return config
