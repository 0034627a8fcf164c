"""How numbers read wherever a person reads them: p-values, interval ends, durations.

Light on imports (the standard library only), so that any stage can phrase its sentences with
these helpers: a p-value below the float range reads ``p < 1e-300``, never ``p = 0``; an
interval end the profile never crossed reads ``open`` (pages, terminal tables and sentences
alike; the JSON keeps ``null``); a duration gets three significant digits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

OPEN = "open"
"""An interval end that the profile never crossed inside the bounds (``null`` in JSON)."""

P_FLOOR = 1e-300
"""p-values below this (down to 0.0, the float underflow) are written ``< 1e-300``."""


def p_value(p: float | None, digits: int = 2) -> str:
    """Return a p-value to ``digits`` significant digits: ``0.013``, ``< 1e-300``; ``—`` if unknown.

    Parameters
    ----------
    p
        The p-value (0 <= p <= 1), or ``None``/``nan`` when the test was not run.
    digits
        Significant digits.

    """
    if p is None or not math.isfinite(p):
        return "\u2014"
    if p < P_FLOOR:
        return f"< {P_FLOOR:.0e}"
    return f"{p:.{digits}g}"


def p_text(p: float | None, digits: int = 2) -> str:
    """Return ``p = 0.013`` or ``p < 1e-300``, for a sentence (see :func:`p_value`)."""
    value = p_value(p, digits)
    return f"p {value}" if value.startswith("<") else f"p = {value}"


def interval_end(value: float | None, digits: int = 4) -> str:
    """Return one end of an interval: the number, or ``open`` for ``None`` or an infinite end."""
    if value is None or not math.isfinite(value):
        return OPEN
    return f"{value:.{digits}g}"


def interval(ends: Sequence[float | None], digits: int = 4) -> str:
    """Return ``[lo, hi]`` with :func:`interval_end` for each end: ``[open, 1.724]``."""
    return f"[{interval_end(ends[0], digits)}, {interval_end(ends[1], digits)}]"


def shown_seconds(seconds: float) -> float:
    """Return ``seconds`` rounded as :func:`duration` prints it (for a result's JSON)."""
    if seconds < 100:
        return float(f"{seconds:.3g}")
    if seconds < 6000:
        return float(round(seconds))
    return float(f"{seconds / 3600:.3g}") * 3600


def duration(seconds: float) -> str:
    """Return a duration with three significant digits: ``8.08 s``, ``413 s``, ``2.5 h``."""
    if seconds < 100:
        return f"{seconds:.3g} s"
    if seconds < 6000:
        return f"{seconds:.0f} s"
    return f"{seconds / 3600:.3g} h"
