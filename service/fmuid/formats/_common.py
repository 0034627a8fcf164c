"""Helpers shared by the readers of standard files."""

from __future__ import annotations

import math

from fmuid.errors import DataError


def finite_number(text: str, where: str) -> float:
    """Return ``text`` as a finite float; a ``DataError`` naming ``where`` otherwise."""
    try:
        value = float(text)
    except ValueError as exc:
        raise DataError(f"{where}: {text!r} is not a number") from exc
    if not math.isfinite(value):
        raise DataError(f"{where}: {text!r} is not finite")
    return value
