"""Reports drawn on their first request: once per job, in a process, never in the event loop.

The first request for a job's report starts one drawing (an asyncio task of the event loop,
keyed by job id, so that concurrent first requests wait for the same drawing); the task makes
the on-disk marker ``reports/<id>.tmp`` (a ``mkdir``, which only one caller wins, so even two
services on one store never draw twice at once) and, in a thread, forks a drawing process from
the warm server (:func:`fmuid.jobs.draw.draw_job_report`) and waits for it, killing it past
:data:`DRAW_TIMEOUT_S`. At most ``settings.draw_workers`` drawings run at once, on a limiter of
their own (the other routes' threads stay free: a crowd of first requests cannot stall status
polls), each within ``settings.draw_memory_mb``. A drawing that fails leaves
``reports/<id>.error`` with the reason, which requests answer with; the first request after
:data:`RETRY_AFTER_S` draws again (the cause may have been passing: memory, a full disk). The job
itself is never touched.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import shutil
import time
from pathlib import Path

import anyio
import anyio.to_thread

from fmuid.jobs.draw import forked_drawing
from fmuid.jobs.housekeeping import remove_paths
from fmuid.jobs.launcher import WarmServer
from fmuid.jobs.layout import DataLayout
from fmuid.processes import kill_group
from fmuid.settings import Settings

logger = logging.getLogger(__name__)

DRAW_TIMEOUT_S = 600.0
"""Longest drawing of one report [s]; its process is killed past it."""
MARKER_POLL_S = 0.1
RETRY_AFTER_S = 5.0
"""A failed drawing is answered with its cause for this long [s]; the next request draws again."""


class DrawingFailed(Exception):
    """No report could be drawn for a job (the message says why)."""


class ReportDrawer:
    """Draws each done job's report once, on demand.

    Parameters
    ----------
    settings
        The data folder, the store and the memory limit of a drawing process.
    warm
        The warm server that forks drawing processes.

    """

    def __init__(self, settings: Settings, warm: WarmServer):
        self.settings = settings
        self.warm = warm
        self.layout = DataLayout(settings.data_dir)
        self._drawing: dict[str, asyncio.Task[str | None]] = {}
        self._limiter: anyio.CapacityLimiter | None = None

    async def report_dir(self, job_id: str) -> Path:
        """Return the folder of the report of done job ``job_id``, drawing it first if needed.

        Raises
        ------
        DrawingFailed
            When the report could not be drawn; the message names the cause.

        """
        directory, error = self.layout.report(job_id), self.layout.report_error(job_id)
        if self._limiter is None:  # made in the event loop, on the first request
            self._limiter = anyio.CapacityLimiter(self.settings.draw_workers)
        if _older_than(error, RETRY_AFTER_S):
            remove_paths([error])
        if not (directory / "index.html").is_file() and not error.is_file():
            task = self._drawing.get(job_id)
            if task is None:
                drawing = anyio.to_thread.run_sync(self._draw, job_id, limiter=self._limiter)
                task = asyncio.ensure_future(drawing)
                self._drawing[job_id] = task
                task.add_done_callback(lambda _: self._drawing.pop(job_id, None))
            reason = await asyncio.shield(task)
            if reason is not None:
                raise DrawingFailed(reason)
        if error.is_file():
            raise DrawingFailed(error.read_text(errors="replace"))
        if not (directory / "index.html").is_file():
            raise DrawingFailed("the drawing process wrote no report")
        return directory

    def _draw(self, job_id: str) -> str | None:
        """Draw in a process unless another drawer holds the marker (then wait for it).

        Returns the reason when not even the marker could be made (nowhere to write it).
        """
        directory, marker = self.layout.report(job_id), self.layout.report_marker(job_id)
        error = self.layout.report_error(job_id)
        try:
            marker.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            return f"cannot make the folder of the reports {marker.parent}: {exc}"
        try:
            marker.mkdir()
        except FileExistsError:
            deadline = time.monotonic() + DRAW_TIMEOUT_S
            while marker.is_dir() and time.monotonic() < deadline:
                time.sleep(MARKER_POLL_S)
            return None
        except OSError as exc:
            return f"cannot make the report folder {marker}: {exc}"
        work = self.layout.report_work(job_id)
        try:
            work.mkdir(parents=True, exist_ok=True)
            arguments = (self._arguments(job_id), work, os.getpid())
            process = self.warm.fork(forked_drawing, arguments, f"fmuid-report-{job_id}")
            process.process.join(DRAW_TIMEOUT_S)
            if not process.exited():
                kill_group(process.pid)
                self._fail(error, f"drawing took longer than {DRAW_TIMEOUT_S:g} s; stopped")
            elif (status := process.wait()) != 0 and not error.is_file():
                self._fail(error, f"the drawing process ended with status {status}")
        except Exception as exc:  # no process: say why instead of leaving the marker
            logger.exception("cannot draw the report of job %s", job_id)
            self._fail(error, f"cannot start a drawing process: {exc}")
        finally:
            if not directory.is_dir():
                shutil.rmtree(marker, ignore_errors=True)
            remove_paths([work])
        return None

    def _arguments(self, job_id: str) -> tuple[Path, Path, str, int]:
        s = self.settings
        return (s.database, s.data_dir, job_id, s.draw_memory_mb)

    @staticmethod
    def _fail(error: Path, reason: str) -> None:
        with contextlib.suppress(OSError):
            error.write_text(reason)


def _older_than(path: Path, age_s: float) -> bool:
    """Whether ``path`` exists and was last written more than ``age_s`` seconds ago."""
    try:
        return time.time() - path.stat().st_mtime > age_s
    except OSError:
        return False
