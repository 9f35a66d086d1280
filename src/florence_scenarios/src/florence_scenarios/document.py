"""One report, two renderings: Markdown (``report.md``) and a self-contained HTML page
(``report.html``, its pictures inlined as data URIs) from the same blocks. ROS-free.

    doc = Document("Florence demo report")
    doc.heading("gotoUser")
    doc.paragraph("The robot found the user in the living room.")
    doc.table(["step", "outcome"], [["gotoUser", "SUCCEEDED"]])
    doc.checks(checks)                    # florence_scenarios.checks.Checks
    doc.image("paths.png", "the robot's and the people's paths")
    doc.write(out_dir)                    # report.md, report.html (atomically)
"""

import base64
import html
import os

from florence_common.files import atomic_write


class Document:
    def __init__(self, title):
        self.title = title
        self.blocks = []

    def heading(self, text, level=2):
        self.blocks.append(("heading", level, str(text)))

    def paragraph(self, text):
        self.blocks.append(("paragraph", str(text)))

    def bullets(self, items):
        self.blocks.append(("bullets", [str(i) for i in items]))

    def table(self, header, rows):
        header = [str(h) for h in header]
        rows = [[_cell(c) for c in row] for row in rows]
        for row in rows:
            if len(row) != len(header):
                raise ValueError(f"table row of {len(row)} cells under a header of {len(header)}: {row}")
        self.blocks.append(("table", header, rows))

    def checks(self, checks):
        self.blocks.append(("checks", [(c.name, c.passed, c.detail) for c in checks]))

    def image(self, path, alt):
        """A PNG written beside the report (``path`` relative to the report's directory or absolute)."""
        self.blocks.append(("image", str(path), str(alt)))

    def code(self, text):
        self.blocks.append(("code", str(text)))

    # --- renderings -----------------------------------------------------------------------------------
    def markdown(self):
        out = [f"# {self.title}", ""]
        for block in self.blocks:
            kind = block[0]
            if kind == "heading":
                out += ["#" * block[1] + " " + block[2], ""]
            elif kind == "paragraph":
                out += [block[1], ""]
            elif kind == "bullets":
                out += [f"- {item}" for item in block[1]] + [""]
            elif kind == "table":
                header, rows = block[1], block[2]
                out += ["| " + " | ".join(_md_cell(h) for h in header) + " |",
                        "| " + " | ".join("---" for _ in header) + " |"]
                out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in rows] + [""]
            elif kind == "checks":
                out += [f"- [{'x' if ok else ' '}] {name}: {detail}" for name, ok, detail in block[1]] + [""]
            elif kind == "image":
                out += [f"![{block[2]}]({os.path.basename(block[1])})", ""]
            elif kind == "code":
                out += ["```", block[1], "```", ""]
        return "\n".join(out)

    def html(self, base_dir="."):
        """The page; images are read from ``base_dir`` and inlined (a missing one is named, not fatal)."""
        e = html.escape
        out = ["<!DOCTYPE html>", "<html><head><meta charset=\"utf-8\">", f"<title>{e(self.title)}</title>",
               f"<style>{_CSS}</style>", "</head><body>", f"<h1>{e(self.title)}</h1>"]
        for block in self.blocks:
            kind = block[0]
            if kind == "heading":
                level = min(max(block[1], 2), 6)
                out.append(f"<h{level}>{e(block[2])}</h{level}>")
            elif kind == "paragraph":
                out.append(f"<p>{e(block[1])}</p>")
            elif kind == "bullets":
                out.append("<ul>" + "".join(f"<li>{e(i)}</li>" for i in block[1]) + "</ul>")
            elif kind == "table":
                head = "".join(f"<th>{e(h)}</th>" for h in block[1])
                body = "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>" for row in block[2])
                out.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
            elif kind == "checks":
                items = "".join(f"<li class=\"{'pass' if ok else 'fail'}\"><b>{'PASSED' if ok else 'FAILED'}</b> "
                                f"{e(name)}: {e(detail)}</li>" for name, ok, detail in block[1])
                out.append(f"<ul class=\"checks\">{items}</ul>")
            elif kind == "image":
                path = block[1] if os.path.isabs(block[1]) else os.path.join(base_dir, block[1])
                try:
                    with open(path, "rb") as f:
                        data = base64.b64encode(f.read()).decode("ascii")
                    out.append(f"<figure><img alt=\"{e(block[2])}\" src=\"data:image/png;base64,{data}\">"
                               f"<figcaption>{e(block[2])}</figcaption></figure>")
                except OSError as exc:
                    out.append(f"<p class=\"fail\">picture {e(block[1])} missing: {e(str(exc))}</p>")
            elif kind == "code":
                out.append(f"<pre>{e(block[1])}</pre>")
        out.append("</body></html>")
        return "\n".join(out)

    def write(self, out_dir, stem="report"):
        """``<stem>.md`` and ``<stem>.html`` in ``out_dir``, each written atomically; returns the Markdown."""
        os.makedirs(out_dir, exist_ok=True)
        text = self.markdown()
        atomic_write(os.path.join(out_dir, f"{stem}.md"), text.encode())
        atomic_write(os.path.join(out_dir, f"{stem}.html"), self.html(out_dir).encode())
        return text


def _cell(value):
    if isinstance(value, float):
        return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    return "-" if value is None else str(value)


def _md_cell(text):
    return text.replace("|", "\\|").replace("\n", " ")


_CSS = ("body{font-family:sans-serif;max-width:70em;margin:1em auto;padding:0 1em;color:#222}"
        "table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #bbb;padding:.2em .5em;"
        "text-align:left;font-size:90%}th{background:#eee}img{max-width:100%}"
        "li.pass b{color:#070}li.fail b,.fail{color:#b00}ul.checks{list-style:none;padding-left:.5em}"
        "figure{margin:1em 0}figcaption{font-size:85%;color:#555}pre{background:#f6f6f6;padding:.5em;"
        "overflow-x:auto}")
