"""HTML reports of fmuid results: ``index.html`` with its figures embedded.

``write_report`` is imported on first use, so that :mod:`fmuid.report.text` (how numbers read)
stays light for any stage that phrases sentences.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__all__ = ["write_report"]

if TYPE_CHECKING:
    from fmuid.report.writer import write_report


def __getattr__(name: str) -> Any:
    if name != "write_report":
        raise AttributeError(f"module 'fmuid.report' has no attribute {name!r}")
    from fmuid.report.writer import write_report

    return write_report
