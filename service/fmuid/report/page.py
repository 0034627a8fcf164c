"""Self-contained HTML pages from the package's jinja2 templates, their PNG figures embedded."""

from __future__ import annotations

import base64
import csv
import io
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import jinja2
from matplotlib.figure import Figure


@cache
def environment() -> jinja2.Environment:
    """Return the template environment: the package templates, every value autoescaped."""
    return jinja2.Environment(
        loader=jinja2.PackageLoader("fmuid.report", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )


def fmt(value: object, digits: int = 4) -> str:
    """Format a cell value: numbers to ``digits`` significant digits, ``None`` or nan as a dash.

    Mappings read ``key = value; ...`` and sequences ``a, b``, so that no Python literal
    reaches a page.
    """
    if isinstance(value, Mapping):
        return "; ".join(f"{k} = {fmt(v, digits)}" for k, v in value.items())
    if isinstance(value, list | tuple | set):
        return ", ".join(fmt(v, digits) for v in value)
    if value is None:
        return "\u2014"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "\u2014"
        if math.isinf(value):
            return "\u221e" if value > 0 else "\u2212\u221e"
        return f"{value:.{digits}g}"
    return str(value)


def with_unit(label: str, unit: str | None) -> str:
    """Return ``label [unit]``, or ``label`` alone when there is no unit."""
    return f"{label} [{unit}]" if unit else label


def file_slug(text: str) -> str:
    """Return a file-name-safe version of ``text``."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "figure"


class HtmlPage:
    """Collect the blocks of a report page and write it, with its figures, from the templates.

    Every text given is escaped by the template environment; nothing is inserted unescaped.

    Parameters
    ----------
    directory
        Where ``index.html`` and the PNG files are written (created if missing).
    title
        The page title and top heading.
    dpi
        Resolution of the PNG files.

    """

    def __init__(self, directory: Path, title: str, *, dpi: int = 100):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.title = title
        self.dpi = dpi
        self.blocks: list[dict[str, Any]] = []
        self._files: set[str] = set()

    def heading(self, text: str, level: int = 2) -> None:
        """Add a heading of ``level`` (2 or deeper)."""
        self.blocks.append({"kind": "heading", "text": text, "level": max(2, int(level))})

    def verdict(self, lines: Sequence[str]) -> None:
        """Add the highlighted verdict box (one paragraph per line)."""
        self.blocks.append({"kind": "verdict", "lines": [str(line) for line in lines if line]})

    def paragraph(self, text: str, *, note: bool = False, at: int | None = None) -> None:
        """Add a paragraph; ``note`` highlights it; ``at`` puts it before block number ``at``."""
        block = {"kind": "paragraph", "text": text, "note": note}
        self.blocks.insert(len(self.blocks) if at is None else at, block)

    def bullets(self, items: Sequence[str], *, css_class: str = "") -> None:
        """Add a bulleted list."""
        self.blocks.append({"kind": "bullets", "items": list(items), "css": css_class})

    def link(self, href: str, text: str) -> None:
        """Add a paragraph holding one link (relative links to sub-reports)."""
        self.blocks.append({"kind": "link", "href": href, "text": text})

    def table(
        self,
        header: Sequence[str],
        rows: Sequence[Sequence[object]],
        *,
        table_id: str | None = None,
        caption: str | None = None,
    ) -> None:
        """Add a table; numbers are right-aligned and formatted with :func:`fmt`."""
        self.blocks.append(
            {
                "kind": "table",
                "header": list(header),
                "rows": [[_cell(c) for c in row] for row in rows],
                "table_id": table_id,
                "caption": caption,
            }
        )

    def figure(self, fig: Figure, name: str, caption: str) -> Path:
        """Show ``fig`` with ``caption``, embedded in the page; also save it as ``<name>.png``.

        The page carries the PNG as a data URI, so that it needs no other file (a saved page
        keeps its figures, a token-protected page needs no signed image links); the file
        beside it is for whoever wants the figure alone.

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
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png", dpi=self.dpi)
        path.write_bytes(buffer.getvalue())
        src = "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")
        self.blocks.append({"kind": "figure", "src": src, "caption": caption})
        return path

    def csv_file(self, name: str, rows: Sequence[Mapping[str, object]], text: str) -> Path:
        """Write ``rows`` (one mapping each, same keys) as ``<name>.csv`` beside the page; link it.

        Numbers keep 10 significant digits, NaN is an empty cell, booleans read true/false.
        """
        stem = file_slug(name)
        path = self.directory / f"{stem}.csv"
        with path.open("w", newline="", encoding="utf-8") as stream:
            writer = csv.writer(stream)
            writer.writerow(list(rows[0]) if rows else [])
            writer.writerows([_csv_cell(v) for v in row.values()] for row in rows)
        self.link(path.name, text)
        return path

    def write(self) -> Path:
        """Render ``page.html`` into ``index.html`` and return its path."""
        text = environment().get_template("page.html").render(title=self.title, blocks=self.blocks)
        path = self.directory / "index.html"
        path.write_text(text, encoding="utf-8")
        return path


def _csv_cell(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.10g}"
    return str(value)


def _cell(value: object) -> dict[str, str]:
    if isinstance(value, Cell):
        return {"text": value.text, "css": value.css}
    num = isinstance(value, int | float) and not isinstance(value, bool)
    return {"text": fmt(value), "css": "num" if num else ""}


@dataclass(frozen=True)
class Cell:
    """A table cell given as text, with its own CSS class (``num``, ``good``, ``bad``)."""

    text: str
    css: str = ""
