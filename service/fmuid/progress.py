"""Progress events that long stages report to their caller (CLI, job worker, notebook)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Progress:
    """One progress event.

    Attributes
    ----------
    stage
        The stage that reports, e.g. ``"fit"``, ``"profile"``, ``"diagnose"``.
    done
        Units of work finished so far (profile points, GA generations, candidates).
    total
        Units of work expected in all; may grow while the stage learns more.
    detail
        Free text for humans, e.g. ``"C_atf +: 7 points"``.
    """

    stage: str
    done: int
    total: int
    detail: str = ""


ProgressCallback = Callable[[Progress], None]
