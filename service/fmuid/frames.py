"""Results as pandas tables: what every result's ``to_frame`` shares.

pandas is optional (the ``report`` extra), so it is imported here, on first use, with a message
saying how to install it. Each result module builds its own rows; this module knows no result.
"""

from __future__ import annotations

from typing import Any

PANDAS_MISSING = (
    "to_frame() needs pandas, which fmuid does not install by default; "
    "install it with: pip install 'fmuid[report]'"
)


def pandas_module() -> Any:
    """Return pandas, or raise an ImportError that says how to install it."""
    try:
        import pandas
    except ImportError as exc:
        raise ImportError(PANDAS_MISSING) from exc
    return pandas


def parameter_frame(rows: dict[str, dict[str, Any]]) -> Any:
    """Return a ``DataFrame`` with one row per parameter, indexed by ``parameter``."""
    frame = pandas_module().DataFrame.from_dict(rows, orient="index")
    frame.index.name = "parameter"
    return frame


def nan_if_none(v: float | None) -> float:
    """Return an open interval end (``None``) as NaN, for a table column of floats."""
    return float("nan") if v is None else float(v)
