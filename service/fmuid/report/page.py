"""A small builder of self-contained HTML pages: escaped text, tables and PNG figures beside."""

from __future__ import annotations

import html
import math
import re
from collections.abc import Sequence
from pathlib import Path

from matplotlib.figure import Figure

CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 1200px; padding: 0 1em; color: #222; line-height: 1.4; }
h1 { font-size: 1.6em; border-bottom: 2px solid #c33; padding-bottom: .2em; }
h2 { font-size: 1.25em; margin-top: 1.8em; color: #333; }
table { border-collapse: collapse; margin: .8em 0; font-size: .9em; }
th, td { border: 1px solid #ccc; padding: .25em .6em; text-align: left; vertical-align: top; }
th { background: #f3f3f3; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
caption { caption-side: top; text-align: left; font-weight: 600; padding-bottom: .3em; }
figure { margin: 1em 0; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: .85em; color: #555; }
p.note { background: #fff6e0; border-left: 4px solid #e0a800; padding: .4em .8em; }
ul.advice li { margin-bottom: .4em; }
"""


def fmt(value: object, digits: int = 4) -> str:
    """Format a cell value: numbers to ``digits`` significant digits, ``None`` as a dash."""
    if value is None:
        return "\u2014"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "\u221e" if value > 0 else "\u2212\u221e"
        return f"{value:.{digits}g}"
    return str(value)


def interval(ends: Sequence[float | None], digits: int = 4) -> str:
    """Format a confidence interval; a null end shows as an unbounded one."""
    lo = "\u2212\u221e" if ends[0] is None else fmt(ends[0], digits)
    hi = "+\u221e" if ends[1] is None else fmt(ends[1], digits)
    return f"[{lo}, {hi}]"


def file_slug(text: str) -> str:
    """Return a file-name-safe version of ``text``."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "figure"


class HtmlPage:
    """Collect the parts of a report page and write it with its figures.

    Every text given is escaped with :func:`html.escape`; nothing is inserted unescaped.

    Parameters
    ----------
    directory
        Where ``index.html`` and the PNG files are written (created if missing).
    title
        The page title and top heading.
    dpi
        Resolution of the PNG files.

    """

    def __init__(self, directory: Path, title: str, *, dpi: int = 90):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.title = title
        self.dpi = dpi
        self._parts: list[str] = [f"<h1>{html.escape(title)}</h1>"]
        self._files: set[str] = set()

    def heading(self, text: str, level: int = 2) -> None:
        """Add a heading of ``level`` (2 or deeper)."""
        self._parts.append(f"<h{level}>{html.escape(text)}</h{level}>")

    def paragraph(self, text: str, *, note: bool = False) -> None:
        """Add a paragraph; ``note`` highlights it."""
        cls = ' class="note"' if note else ""
        self._parts.append(f"<p{cls}>{html.escape(text)}</p>")

    def bullets(self, items: Sequence[str], *, css_class: str = "") -> None:
        """Add a bulleted list."""
        cls = f' class="{html.escape(css_class)}"' if css_class else ""
        lis = "".join(f"<li>{html.escape(item)}</li>" for item in items)
        self._parts.append(f"<ul{cls}>{lis}</ul>")

    def link(self, href: str, text: str) -> None:
        """Add a paragraph holding one link (relative links to sub-reports)."""
        self._parts.append(
            f'<p><a href="{html.escape(href, quote=True)}">{html.escape(text)}</a></p>'
        )

    def table(
        self,
        header: Sequence[str],
        rows: Sequence[Sequence[object]],
        *,
        table_id: str | None = None,
        caption: str | None = None,
    ) -> None:
        """Add a table; numbers are right-aligned and formatted with :func:`fmt`."""
        attr = f' id="{html.escape(table_id, quote=True)}"' if table_id else ""
        out = [f"<table{attr}>"]
        if caption:
            out.append(f"<caption>{html.escape(caption)}</caption>")
        out.append("<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>")
        for row in rows:
            cells = []
            for cell in row:
                num = isinstance(cell, int | float) and not isinstance(cell, bool)
                cls = ' class="num"' if num else ""
                cells.append(f"<td{cls}>{html.escape(fmt(cell))}</td>")
            out.append("<tr>" + "".join(cells) + "</tr>")
        out.append("</table>")
        self._parts.append("".join(out))

    def figure(self, fig: Figure, name: str, caption: str) -> Path:
        """Save ``fig`` as ``<name>.png`` beside the page and show it with ``caption``.

        Returns
        -------
        Path
            The PNG file written.

        """
        stem = file_slug(name)
        while f"{stem}.png" in self._files:
            stem += "_"
        self._files.add(f"{stem}.png")
        path = self.directory / f"{stem}.png"
        fig.savefig(path, dpi=self.dpi)
        src = html.escape(path.name, quote=True)
        self._parts.append(
            f'<figure><img src="{src}" alt="{html.escape(caption, quote=True)}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )
        return path

    def write(self) -> Path:
        """Write ``index.html`` and return its path."""
        body = "\n".join(self._parts)
        text = (
            '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f"<title>{html.escape(self.title)}</title>\n<style>{CSS}</style>\n</head>\n"
            f"<body>\n{body}\n</body>\n</html>\n"
        )
        path = self.directory / "index.html"
        path.write_text(text, encoding="utf-8")
        return path
