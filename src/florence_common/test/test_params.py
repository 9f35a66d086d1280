"""Parameter tables: read, validate with errors that name the parameter, render docs."""

import math

import pytest

from florence_common.params import FRAME, Param, ParamError, ParamTable

pytestmark = pytest.mark.unit

TABLE = ParamTable(
    Param("rate", float, 50.0, "publishing rate", unit="Hz", gt=0),
    Param("count", int, 3, "how many", ge=1, le=10),
    Param("enabled", bool, True, "switch"),
    Param("mode", str, "twist", "drive mode", choices=("twist", "drive")),
    Param("frame_id", FRAME, "odom", "fixed frame"),
    Param("inputs", list, None, "the sources", optional=True),
)


def test_defaults_and_attribute_access():
    p = TABLE.defaults()
    assert (p.rate, p.count, p.enabled, p.mode, p.frame_id, p.inputs) == (50.0, 3, True, "twist", "odom", None)
    assert p["rate"] == 50.0 and dict(p)["count"] == 3
    with pytest.raises(AttributeError):
        p.rate = 1.0


def test_read_from_a_getter_converts_types():
    given = {"rate": 10, "count": 4.0, "enabled": 0, "frame_id": "/map"}
    p = TABLE.read(given.get)
    assert p.rate == 10.0 and isinstance(p.rate, float)
    assert p.count == 4 and isinstance(p.count, int)
    assert p.enabled is False
    assert p.frame_id == "map"  # tf2 refuses a leading slash


@pytest.mark.parametrize(("values", "message"), [
    ({"rate": -1.0}, "~rate must be > 0 [Hz], got -1.0"),
    ({"rate": math.nan}, "~rate must be finite [Hz], got nan"),
    ({"rate": "fast"}, "~rate must be a number (float) [Hz], got 'fast'"),
    ({"count": 11}, "~count must be >= 1 and <= 10, got 11"),
    ({"count": 2.5}, "~count must be a whole number, got 2.5"),
    ({"enabled": "yes"}, "~enabled must be true or false, got 'yes'"),
    ({"mode": "fly"}, "~mode must be one of 'twist', 'drive', got 'fly'"),
    ({"inputs": {"a": 1}}, "~inputs must be a list, got {'a': 1}"),
])
def test_one_clear_error_names_the_parameter(values, message):
    with pytest.raises(ParamError) as err:
        TABLE.validate(values)
    assert str(err.value) == message


def test_every_bad_parameter_is_named_at_once():
    with pytest.raises(ParamError) as err:
        TABLE.validate({"rate": 0.0, "count": 0})
    assert "~rate" in str(err.value) and "~count" in str(err.value)


def test_unknown_names_are_refused_by_validate():
    with pytest.raises(ParamError, match="~speed"):
        TABLE.validate({"speed": 1.0})


def test_a_custom_check():
    table = ParamTable(Param("pair", list, [0, 1], "two numbers",
                            check=lambda v: None if len(v) == 2 else "must have two entries"))
    assert table.validate({"pair": [3, 4]}).pair == [3, 4]
    with pytest.raises(ParamError, match="~pair must have two entries"):
        table.validate({"pair": [1]})


def test_a_default_outside_its_own_range_is_a_bug():
    with pytest.raises(ParamError):
        Param("rate", float, 0.0, "rate", gt=0)
    with pytest.raises(ValueError, match="declared twice"):
        ParamTable(Param("a", int, 1, "a"), Param("a", int, 2, "a"))


def test_docstring_and_markdown():
    doc = TABLE.docstring(indent=4)
    assert "    ~rate (float, 50, Hz; > 0): publishing rate" in doc.splitlines()
    assert '    ~mode (str, "twist"; one of \'twist\', \'drive\'): drive mode' in doc.splitlines()
    assert "~inputs (list, unset): the sources" in doc
    md = TABLE.markdown().splitlines()
    assert md[0].startswith("| parameter | type | default | unit | range | meaning |")
    assert "| `~rate` | float | `50` | Hz | > 0 | publishing rate |" in md
    assert len(md) == 2 + len(TABLE.params)


def test_a_table_of_relative_names():
    table = ParamTable(Param("hokuyo_node/max_ang", float, 1.57, "the Hokuyo's last angle", unit="rad", gt=0),
                       prefix="")
    assert table.validate({"hokuyo_node/max_ang": 2.0}).hokuyo_node_max_ang == 2.0
    with pytest.raises(ParamError, match=r"^hokuyo_node/max_ang must be > 0 \[rad\], got -1"):
        table.validate({"hokuyo_node/max_ang": -1})
    assert table.markdown().splitlines()[2].startswith("| `hokuyo_node/max_ang` |")
    with pytest.raises(ValueError, match="prefixes"):
        table + TABLE
