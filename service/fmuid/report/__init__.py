"""HTML reports of fmuid results: ``index.html`` with PNG figures beside it."""

from fmuid.report.writer import write_report

__all__ = ["write_report"]
