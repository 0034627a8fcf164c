"""Terminal output of the ``fmuid`` command: progress, result tables, model info, Ctrl-C.

A terminal gets a progress bar (rich) and aligned tables; a pipe or a log file gets plain,
throttled log lines instead of the bar.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
import time
from collections.abc import Sequence
from types import FrameType, TracebackType
from typing import TYPE_CHECKING, Any

from fmuid.progress import Progress
from fmuid.readable import OPEN

if TYPE_CHECKING:
    from fmuid.estimation.result import FitResult
    from fmuid.model.info import ModelInfo, VariableInfo
    from fmuid.profiling.result import ProfileResult

log = logging.getLogger("fmuid")

EXIT_INTERRUPTED = 130


class ProgressDisplay:
    """Receives ``Progress`` events: a bar per stage on a terminal, log lines every 2 s otherwise.

    Use as a context manager around the stage so that the bar is closed on the way out.
    """

    def __init__(self, tty: bool | None = None, console: Any = None) -> None:
        self.tty = sys.stderr.isatty() if tty is None else tty
        self.console = console
        self.last = 0.0
        self._bar: Any = None
        self._tasks: dict[str, Any] = {}

    def __enter__(self) -> ProgressDisplay:
        if self.tty:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                TextColumn,
                TimeElapsedColumn,
            )
            from rich.progress import Progress as Bar
            from rich.table import Column

            # name, bar, count and clock keep their width; the detail takes what is left of
            # the line (80 columns leave it about 30) and ends in an ellipsis
            self._bar = Bar(
                TextColumn("{task.description:>8s}", table_column=Column(no_wrap=True)),
                BarColumn(bar_width=12),
                MofNCompleteColumn(table_column=Column(no_wrap=True)),
                TimeElapsedColumn(),
                TextColumn(
                    "{task.fields[detail]}",
                    table_column=Column(no_wrap=True, overflow="ellipsis", ratio=1),
                ),
                console=self.console or Console(stderr=True),
                transient=False,
                expand=True,
            )
            self._bar.start()
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if self._bar is not None:
            if kind is None:  # the stage finished: its estimate of the work left is moot
                for task in self._bar.tasks:
                    total = task.total if task.total is not None else task.completed
                    self._bar.update(task.id, completed=total, total=total)
            self._bar.stop()

    def __call__(self, event: Progress) -> None:
        """Show one event."""
        if self._bar is not None:
            task = self._tasks.get(event.stage)
            if task is None:  # a total of 0: not known ahead (the refinement); shown as "n/?"
                task = self._bar.add_task(event.stage, total=event.total or None, detail="")
                self._tasks[event.stage] = task
            self._bar.update(task, completed=event.done, detail=event.detail)
            if event.total:
                self._bar.update(task, total=event.total)
            return
        now = time.monotonic()
        if (event.done < event.total or not event.total) and now - self.last < 2.0:
            return
        self.last = now
        log.info("%s: %d/%d %s", event.stage, event.done, event.total, event.detail)


def log_handler(tty: bool) -> logging.Handler:
    """Return a log handler on stderr that does not break the progress bar on a terminal."""
    if tty:
        from rich.console import Console
        from rich.logging import RichHandler

        return RichHandler(console=Console(stderr=True), show_path=False)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    return handler


def _number(value: float | None) -> str:
    return OPEN if value is None else f"{value:.6g}"


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """Format rows under a header, columns left-aligned and padded to their widest cell."""
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines = [
        "  ".join(str(c).ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
        for r in [header, *rows]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def fit_table(result: FitResult) -> str:
    """Format a fit as a table: estimate, unit, bounds (and which estimates lie on one)."""
    on_bound = {n for n, p in result.to_dict()["parameters"].items() if p["at_bound"]}
    rows = [
        [
            name,
            _number(result.estimates[name]),
            result.units.get(name, ""),
            f"[{_number(result.lower[name])}, {_number(result.upper[name])}]",
            *(["yes" if name in on_bound else "no"] if on_bound else []),
        ]
        for name in result.names
    ]
    header = ["parameter", "estimate", "unit", "bounds", *(["on a bound"] if on_bound else [])]
    text = table(header, rows)
    return f"{text}\nchi2 {result.chi2:.6g} with {result.n_data} data points"


def profile_table(result: ProfileResult) -> str:
    """Format the profile result as a table: estimate, unit, both intervals and the label.

    An interval end that the profile never crossed inside the bounds reads ``open``.
    """
    level = f"{result.confidence:.0%}"
    rows = []
    for name, p in result.parameters.items():
        lo, hi = p.ci_simultaneous
        plo, phi = p.ci_pointwise
        status = p.status.replace("_", " ")
        if p.limited_by:
            status += f" (limited by {', '.join(p.limited_by)})"
        rows.append(
            [
                name,
                _number(p.estimate),
                result.fit.units.get(name, ""),
                f"[{_number(lo)}, {_number(hi)}]",
                f"[{_number(plo)}, {_number(phi)}]",
                status,
            ]
        )
    header = [
        "parameter",
        "estimate",
        "unit",
        f"{level} simultaneous",
        f"{level} pointwise",
        "label",
    ]
    text = f"{table(header, rows)}\nchi2 {result.chi2:.6g} with {result.fit.n_data} data points"
    if any(OPEN in row[3] + row[4] for row in rows):
        text += f"\n'{OPEN}': the profile stays below the threshold up to the parameter's bound"
    return text


def info_text(info: ModelInfo) -> str:
    """Human-readable ``fmuid info``: the model, then a table per causality."""
    kinds = ", ".join(info.interfaces)
    parts = [
        f"{info.model_name}: {info.description}".rstrip(": "),
        f"file {info.path}",
        f"FMI {info.fmi_version}, {kinds} (fmuid drives {info.interface})",
    ]

    def section(title: str, variables: Sequence[VariableInfo], start: bool) -> None:
        if not variables:
            parts.append(f"\n{title}: none")
            return
        header = ["name", "type", "unit", *(["start", "bounds"] if start else []), "description"]
        rows = []
        for v in variables:
            extra = []
            if start:
                bounds = (
                    f"[{_number(v.lower)}, {_number(v.upper)}]"
                    if v.lower is not None or v.upper is not None
                    else ""
                )
                extra = ["" if v.start is None else f"{v.start:.6g}", bounds]
            rows.append([v.name, v.type, v.unit, *extra, v.description])
        parts.append(f"\n{title}:\n{table(header, rows)}")

    section("parameters", info.parameters, True)
    section("inputs", info.inputs, False)
    section("outputs", info.outputs, False)
    if info.health is not None:
        h = info.health
        start, stop = h.horizon_s
        if not h.simulates:
            found = f"does not simulate at its start values: {h.message}"
        else:
            found = "simulates at its start values; " + (
                "repeated runs are equal" if h.deterministic else "repeated runs DIFFER"
            )
            found += {
                True: "; a reset run equals a fresh instance's",
                None: "",
                False: "; its reset is UNRELIABLE (fmuid gives every run a fresh instance)",
            }[h.reset_reliable]
            if h.ignored:
                found += f"; it IGNORES the parameters {', '.join(h.ignored)} that fmuid sets"
        parts.append(f"\nhealth ({start:g}-{stop:g} s): {found}")
    return "\n".join(parts)


def _stop_now(signum: int, frame: FrameType | None) -> None:
    """End at once on Ctrl-C: terminate our worker processes, then exit with status 130."""
    import multiprocessing

    children = multiprocessing.active_children()
    for child in children:
        child.terminate()
    deadline = time.monotonic() + 1.0
    for child in children:
        child.join(max(0.0, deadline - time.monotonic()))
        if child.is_alive():
            child.kill()
    try:
        if sys.stderr.isatty():
            sys.stderr.write("\x1b[?25h")  # the progress bar hides the cursor
        sys.stderr.write("\ninterrupted\n")
        sys.stdout.flush()
        sys.stderr.flush()
    finally:
        os._exit(EXIT_INTERRUPTED)


def exit_on_interrupt() -> None:
    """Make Ctrl-C (SIGINT) end the command within a second with status 130."""
    signal.signal(signal.SIGINT, _stop_now)
