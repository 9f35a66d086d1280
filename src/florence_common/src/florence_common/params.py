"""Parameter tables: every ROS parameter of a node declared once, with its type, default,
unit, allowed range and meaning; read from any getter, validated with one clear error,
and rendered into the node's docstring and its README.

    PARAMS = ParamTable(
        Param("check_rate", float, 50.0, "how often silent inputs are expired", unit="Hz", gt=0),
        Param("stop_on_idle", bool, True, "publish one zero Twist when the active input times out"),
    )
    p = PARAMS.read(lambda name, default: rospy.get_param("~" + name, default))
    p.check_rate  # 50.0

No rospy here: the offline tools read the same tables from a launch file's values or a
dict (``PARAMS.read(values.get)``), and the tests call it with plain dicts.
"""

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

FRAME = "frame"  # a tf frame id: a str whose leading '/' is dropped (tf2 refuses it)

_TYPE_NAMES = {float: "float", int: "int", bool: "bool", str: "str", list: "list", dict: "dict", FRAME: "str"}


class ParamError(ValueError):
    """One or more parameters are out of range or of the wrong type; the message names each."""


@dataclass(frozen=True)
class Param:
    """One parameter: ``name`` (relative to the node's private namespace, '/' for nested),
    ``type`` (float, int, bool, str, list, dict or FRAME), ``default``, ``doc``; ``unit``
    (SI, e.g. "m", "rad/s", "Hz"); bounds ``gt``/``ge``/``lt``/``le`` for numbers;
    ``choices`` for enumerations; ``optional`` lets None stand for "not set"; ``finite``
    (numbers) refuses NaN and infinity; ``check(value)`` returns a problem text or None."""

    name: str
    type: Any
    default: Any
    doc: str
    unit: str = ""
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    choices: tuple | None = None
    optional: bool = False
    finite: bool = True
    check: Callable[[Any], str | None] | None = None

    def __post_init__(self):
        if self.type not in _TYPE_NAMES:
            raise TypeError(f"parameter {self.name}: unsupported type {self.type!r}")
        if self.default is not None or not self.optional:
            self.convert(self.default)  # a table whose default is out of its own range is a bug

    # --- reading -------------------------------------------------------------------------------
    def convert(self, raw, prefix="~"):
        """The value of ``raw`` as this parameter's type; ParamError when it does not fit (its
        message names the parameter as ``prefix + name``)."""
        try:
            if raw is None:
                if self.optional:
                    return None
                raise self._error("must be set", raw)
            value = self._typed(raw)
            problem = self._range_problem(value)
            if problem is None and self.check is not None:
                problem = self.check(value)
            if problem:
                raise self._error(problem, raw)
            return value
        except ParamError as exc:
            if prefix == "~":
                raise
            raise ParamError(prefix + str(exc)[1:]) from None

    def _typed(self, raw):
        t = self.type
        if t is bool:
            if isinstance(raw, bool):
                return raw
            if isinstance(raw, int) and raw in (0, 1):  # C++-style 0/1 from YAML
                return bool(raw)
            raise self._error("must be true or false", raw)
        if t in (float, int):
            if isinstance(raw, bool) or not isinstance(raw, (int, float)):
                raise self._error(f"must be a number ({_TYPE_NAMES[t]})", raw)
            if t is int:
                if isinstance(raw, float) and not raw.is_integer():
                    raise self._error("must be a whole number", raw)
                return int(raw)
            value = float(raw)
            if self.finite and not math.isfinite(value):
                raise self._error("must be finite", raw)
            return value
        if t in (str, FRAME):
            if not isinstance(raw, str):
                raise self._error("must be a string", raw)
            return raw.lstrip("/") if t == FRAME else raw
        if not isinstance(raw, t):
            raise self._error(f"must be a {_TYPE_NAMES[t]}", raw)
        return raw

    def _range_problem(self, value):
        if self.choices is not None and value not in self.choices:
            return f"must be one of {', '.join(repr(c) for c in self.choices)}"
        if self.type in (float, int) and not (isinstance(value, float) and math.isnan(value)):
            bounds = self.range_text()
            if ((self.gt is not None and not value > self.gt) or (self.ge is not None and not value >= self.ge)
                    or (self.lt is not None and not value < self.lt) or (self.le is not None and not value <= self.le)):
                return f"must be {bounds}"
        return None

    def _error(self, problem, raw):
        unit = f" [{self.unit}]" if self.unit else ""
        return ParamError(f"~{self.name} {problem}{unit}, got {raw!r}")

    # --- documentation -----------------------------------------------------------------------------
    def range_text(self):
        """The allowed range in words: "> 0", ">= 0 and < 1", "one of 'a', 'b'" or ""."""
        if self.choices is not None:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        parts = [f"{op} {_num(v)}" for op, v in ((">", self.gt), (">=", self.ge), ("<", self.lt), ("<=", self.le))
                 if v is not None]
        return " and ".join(parts)

    def describe(self, prefix="~"):
        """One line for a docstring: ``~name (type, default, unit; range): doc``."""
        meta = [_TYPE_NAMES[self.type], _default_text(self.default)]
        if self.unit:
            meta.append(self.unit)
        rng = self.range_text()
        return f"{prefix}{self.name} ({', '.join(meta)}{'; ' + rng if rng else ''}): {self.doc}"


def _num(v):
    return f"{v:g}" if isinstance(v, float) else str(v)


def _default_text(value):
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        return _num(value)
    return repr(value).replace("True", "true").replace("False", "false").replace("None", "unset")


class Params(Mapping):
    """Validated values, read-only, by attribute (``p.rate``) or key (``p["rate"]``)."""

    def __init__(self, values):
        object.__setattr__(self, "_values", dict(values))

    def __getattr__(self, name):
        try:
            return self._values[name]
        except KeyError:
            raise AttributeError(name) from None

    def __setattr__(self, name, value):
        raise AttributeError("parameters are read-only")

    def __getitem__(self, key):
        return self._values[key]

    def __iter__(self):
        return iter(self._values)

    def __len__(self):
        return len(self._values)

    def __repr__(self):
        return f"Params({self._values!r})"


class ParamTable:
    """The parameters of one node (or one component), in the order they are documented.

    ``prefix`` is how their names resolve: "~" (the node's private namespace, the usual case) or
    "" (relative names, e.g. another node's ``hokuyo_node/max_ang``)."""

    def __init__(self, *params, prefix="~"):
        self.prefix = prefix
        names = [p.name for p in params]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"parameters declared twice: {dup}")
        self.params = tuple(params)

    def __iter__(self):
        return iter(self.params)

    def __getitem__(self, name):
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)

    def __add__(self, other):
        if other.prefix != self.prefix:
            raise ValueError("tables of different prefixes do not add up")
        return ParamTable(*self.params, *other.params, prefix=self.prefix)

    def names(self):
        return [p.name for p in self.params]

    def read(self, get):
        """Values from ``get(name, default)`` (e.g. ``rospy.get_param("~" + name, default)``).

        Raises one ParamError that names every parameter out of range."""
        values, problems = {}, []
        for p in self.params:
            try:
                values[p.name.replace("/", "_")] = p.convert(get(p.name, p.default), self.prefix)
            except ParamError as exc:
                problems.append(str(exc))
        if problems:
            raise ParamError("; ".join(problems))
        return Params(values)

    def validate(self, values):
        """Values from a dict: names it lacks take their defaults; unknown names are refused."""
        unknown = sorted(set(values) - set(self.names()))
        if unknown:
            raise ParamError(f"unknown parameter(s) {', '.join(self.prefix + n for n in unknown)}")
        return self.read(values.get)

    def defaults(self):
        return self.read(lambda _name, default: default)

    def docstring(self, indent=4):
        """The ``ROS Parameters:`` lines of a node's docstring."""
        pad = " " * indent
        return "\n".join(pad + p.describe(self.prefix) for p in self.params)

    def markdown(self):
        """The README table: name, type, default, unit, allowed range, meaning."""
        rows = ["| parameter | type | default | unit | range | meaning |", "| --- | --- | --- | --- | --- | --- |"]
        for p in self.params:
            cells = (f"`{self.prefix}{p.name}`", _TYPE_NAMES[p.type], f"`{_default_text(p.default)}`", p.unit,
                     p.range_text(), p.doc)
            rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
        return "\n".join(rows)
