"""Pieces of error messages shared by the data and spec checks: quoted names, suggestions."""

from __future__ import annotations

import difflib
import json
from collections.abc import Collection, Iterable
from itertools import islice
from typing import Any

MAX_LISTED = 30
"""Most names a message lists before it says how many more there are."""
MAX_SUGGEST_CANDIDATES = 5_000
"""Above this many known names, no close match is searched (each search is linear in them)."""


def names(items: Iterable[object], quote: str = "'") -> str:
    """Comma-separated quoted names for a message, at most :data:`MAX_LISTED` of them."""
    listed = list(islice(items, MAX_LISTED + 1))
    text = ", ".join(f"{quote}{n}{quote}" for n in listed[:MAX_LISTED])
    if len(listed) > MAX_LISTED:
        text += ", ..."
    return text or "none"


def suggest(name: str, candidates: Collection[str], what: str) -> str:
    """Return `` (did you mean 'x'?)`` or `` (<what>: a, b, ...)`` for a message."""
    if len(candidates) <= MAX_SUGGEST_CANDIDATES:
        folded = {candidate.casefold(): candidate for candidate in candidates}
        matches = difflib.get_close_matches(name.casefold(), list(folded), n=3, cutoff=0.5)
        close = [folded[match] for match in matches]
        if close:
            return f" (did you mean {' or '.join(repr(c) for c in close)}?)"
    return f" ({what}: {names(sorted(candidates), quote='')})"


def show(value: Any, limit: int = 60) -> str:
    """Render an input value as JSON text for a message."""
    text = json.dumps(value, default=str)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def quote(text: str, limit: int = 40) -> str:
    """Shorten a cell's text for a message."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


def capped(problems: list[str], limit: int = 20) -> str:
    """Join problem lines, at most ``limit`` of them, then say how many were left out."""
    text = "\n".join(problems[:limit])
    if len(problems) > limit:
        text += f"\n... and {len(problems) - limit} more problems"
    return text
