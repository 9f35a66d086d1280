"""florence_scenarios.document: one report rendered as Markdown and as a self-contained HTML page."""

import base64

import pytest
from florence_scenarios.checks import Checks
from florence_scenarios.document import Document

pytestmark = pytest.mark.unit

PNG = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJ"
                       "RU5ErkJggg==")


def report(tmp_path):
    (tmp_path / "paths.png").write_bytes(PNG)
    checks = Checks()
    checks.add("user found", True, "0.52 m from the user")
    checks.add("no collision", False, "1 bump <at> the sofa")
    doc = Document("Florence demo report")
    doc.heading("gotoUser")
    doc.paragraph("The robot found the user & came close.")
    doc.table(["step", "outcome", "error [m]"], [["gotoUser", "SUCCEEDED", 0.0512], ["a|b", None, 3]])
    doc.checks(checks)
    doc.image("paths.png", "paths over the map")
    doc.image("missing.png", "a picture that was not drawn")
    return doc


def test_markdown_has_every_block_in_order(tmp_path):
    md = report(tmp_path).markdown()
    assert md.index("# Florence demo report") < md.index("## gotoUser") < md.index("| step |")
    assert "| gotoUser | SUCCEEDED | 0.0512 |" in md
    assert "| a\\|b | - | 3 |" in md  # a pipe in a cell does not split it
    assert "- [x] user found: 0.52 m from the user" in md and "- [ ] no collision:" in md
    assert "![paths over the map](paths.png)" in md


def test_html_is_escaped_and_inlines_its_pictures(tmp_path):
    page = report(tmp_path).html(str(tmp_path))
    assert "found the user &amp; came close" in page and "&lt;at&gt;" in page
    assert "data:image/png;base64," + base64.b64encode(PNG).decode() in page
    assert "picture missing.png missing" in page
    assert "<b>PASSED</b> user found" in page and "<b>FAILED</b> no collision" in page


def test_write_puts_both_files_atomically(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "paths.png").write_bytes(PNG)
    doc = report(tmp_path)
    text = doc.write(str(out))
    assert (out / "report.md").read_text() == text
    assert "data:image/png;base64," in (out / "report.html").read_text()
    assert sorted(p.name for p in out.iterdir()) == ["paths.png", "report.html", "report.md"]


def test_a_row_of_the_wrong_width_is_refused():
    with pytest.raises(ValueError, match="row of 1 cells under a header of 2"):
        Document("x").table(["a", "b"], [["only one"]])
