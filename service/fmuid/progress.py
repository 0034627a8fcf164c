"""Progress events that long stages report to their caller (CLI, job worker, notebook)."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


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
        Units of work expected in all; may grow while the stage learns more; 0 when not
        known ahead (the trust-region refinement: ``done`` counts its evaluations).
    detail
        Free text for humans, e.g. ``"C_atf +: 7 points"``.
    """

    stage: str
    done: int
    total: int
    detail: str = ""


ProgressCallback = Callable[[Progress], None]


class NotebookProgress:
    """Progress in a Jupyter notebook: one line per stage, updated in place under the cell.

    Drawn with IPython's display (an HTML ``<progress>`` bar, the count, the time since the
    stage's first event and its detail), at most every ``interval`` seconds; it needs no
    widget library. ``fmuid.fit``, ``profile``, ``diagnose`` and ``design`` use it when called
    from a notebook without ``progress=`` (:func:`default_progress`).

    Parameters
    ----------
    show
        Receives the HTML of all lines each time they change (default: an IPython display
        updated in place).
    interval
        Least seconds between two updates (the last event of a stage always shows).

    """

    def __init__(self, show: Callable[[str], None] | None = None, interval: float = 0.25):
        self.show = show or _IPythonDisplay()
        self.interval = interval
        self.last = 0.0
        self.stages: dict[str, tuple[Progress, float]] = {}

    def __call__(self, event: Progress) -> None:
        """Show one event."""
        now = time.monotonic()
        first = self.stages.get(event.stage, (event, now))[1]
        self.stages[event.stage] = (event, first)
        if now - self.last < self.interval and 0 < event.total and event.done < event.total:
            return
        self.last = now
        self.show("".join(_line(e, now - t0) for e, t0 in self.stages.values()))


def _line(event: Progress, seconds: float) -> str:
    from html import escape

    bar = f'<progress value="{event.done}" max="{event.total}"></progress>'
    if not event.total:  # not known ahead: an indeterminate bar
        bar = "<progress></progress>"
    count = f"{event.done}/{event.total or '?'}"
    clock = f"{int(seconds) // 60}:{int(seconds) % 60:02d}"
    return (
        f"<div style='font-family: monospace'>{escape(event.stage):>8} {bar} {count} {clock} "
        f"{escape(event.detail)}</div>"
    )


class _IPythonDisplay:
    """An IPython display under the running cell, made on the first call, then updated."""

    def __init__(self) -> None:
        self.handle: Any = None

    def __call__(self, html: str) -> None:
        from IPython.display import HTML, display

        if self.handle is None:
            self.handle = display(HTML(html), display_id=True)
        else:
            self.handle.update(HTML(html))


def in_notebook() -> bool:
    """Whether this runs in a Jupyter kernel (an IPython shell with a kernel)."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    return shell is not None and getattr(shell, "kernel", None) is not None


def default_progress(progress: ProgressCallback | None) -> ProgressCallback | None:
    """Return ``progress``, or a :class:`NotebookProgress` when none is given in a notebook.

    Pass ``progress=lambda event: None`` to a stage to silence it in a notebook.
    """
    if progress is None and in_notebook():
        return NotebookProgress()
    return progress
