"""yamlfile: YAML with line numbers, errors that name the file and the line."""

import pytest

from florence_common import yamlfile

pytestmark = pytest.mark.unit

TEXT = """\
# comment
rooms:
  kitchen:
    - [5.0, 0.0]
    - [8.0, 0.0]
  hall: {x: 1}
"""


def test_lines_of_mapping_entries_and_list_items():
    data = yamlfile.loads(TEXT, "rooms.yaml")
    assert data == {"rooms": {"kitchen": [[5.0, 0.0], [8.0, 0.0]], "hall": {"x": 1}}}
    rooms = data["rooms"]
    assert data.line_of("rooms") == 2
    assert rooms.line_of("kitchen") == 3 and rooms.line_of("hall") == 6
    assert rooms["kitchen"].line_of(1) == 5
    assert rooms["hall"].line_of("x") == 6
    assert yamlfile.line_of({"plain": 1}, "plain") == 0  # a dict from elsewhere: unknown line


@pytest.mark.parametrize("text, line, words", [
    ("a: [1, 2\nb: 3\n", 2, "not valid YAML"),
    ("a: 1\na: 2\n", 2, "duplicate key 'a'"),
    ("a:\n  - 1\n - 2\n", 3, "not valid YAML"),
])
def test_syntax_errors_name_the_file_and_line(text, line, words):
    with pytest.raises(yamlfile.YamlError, match=words) as info:
        yamlfile.loads(text, "/x/hotspots.yaml")
    assert str(info.value).startswith(f"/x/hotspots.yaml:{line}: ")
    assert info.value.line == line


def test_unreadable_file(tmp_path):
    with pytest.raises(yamlfile.YamlError, match="cannot be read"):
        yamlfile.load(tmp_path / "missing.yaml")
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(yamlfile.YamlError, match=str(binary)):
        yamlfile.load(binary)


def test_only_safe_types():
    with pytest.raises(yamlfile.YamlError):
        yamlfile.loads("a: !!python/object/apply:os.system ['true']\n")
