"""Draw the HTML report of a done job, on its first request, in a process of its own.

A job stores its result and ends; nothing draws until someone asks for the report. Then the API
(:mod:`fmuid.api.drawing`) makes ``reports/<id>.tmp`` (the marker that says "being drawn": one
``mkdir`` succeeds, so one drawing at a time) and starts :func:`draw_job_report` in a process
forked by the warm server (matplotlib is imported there already). That process reads the result,
the FMU, the data and the spec back from the store, draws into the marker folder and renames it
to ``reports/<id>/``; when drawing fails it writes the reason to ``reports/<id>.error`` instead
(paths: :class:`fmuid.jobs.layout.DataLayout`). The job's row is never touched: a report that
cannot be drawn leaves the job ``done``. The result object is read back from the stored JSON
(:func:`fmuid.results.result_from_dict`) and drawn by the runner of the job's kind.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

from fmuid.engine.guard import die_with_pool_owner
from fmuid.jobs.kinds import JobInputs, runner
from fmuid.jobs.layout import DataLayout
from fmuid.jobs.proc import JOB_NICENESS
from fmuid.jobs.store import Job, JobStore
from fmuid.processes import limit_memory

logger = logging.getLogger(__name__)


def write_report(job: Job, result: Any, inputs: JobInputs, layout: DataLayout) -> None:
    """Write a job's HTML report (or its error file saying why not).

    It is drawn by the runner of the job's kind (:mod:`fmuid.jobs.kinds`) in the job's report
    marker (made by whoever started the drawing) and renamed to the job's report folder.
    """
    directory, tmp = layout.report(job.id), layout.report_marker(job.id)
    error_file = layout.report_error(job.id)
    try:
        runner(job.kind).draw(result, inputs, tmp)
    except Exception as exc:  # a failed report must not fail a finished job
        logger.exception("report of %s failed", job.id)
        shutil.rmtree(tmp, ignore_errors=True)
        with contextlib.suppress(OSError):
            error_file.write_text(f"{type(exc).__name__}: {exc}")
        return
    shutil.rmtree(directory, ignore_errors=True)
    os.replace(tmp, directory)
    error_file.unlink(missing_ok=True)


def draw_job_report(db_path: Path, data_dir: Path, job_id: str, memory_mb: int) -> None:
    """Draw the report of the done job ``job_id`` (body of a drawing process).

    Every failure, reading the job back included, ends in ``reports/<id>.error``.
    """
    from fmuid.intake.inputs import load_job_inputs
    from fmuid.results import result_from_dict

    layout = DataLayout(data_dir)
    tmp, error_file = layout.report_marker(job_id), layout.report_error(job_id)
    logger.info("drawing the report of job %s", job_id)
    try:
        limit_memory(memory_mb)
        store = JobStore(db_path, data_dir)
        job = store.get(job_id)
        text = store.result(job_id)
        if job is None or text is None:
            raise LookupError(f"job {job_id} has no stored result")
        with tempfile.TemporaryDirectory(prefix=f"fmuid-report-{job_id[:8]}-") as work:
            inputs = load_job_inputs(store, job, Path(work))
            result = result_from_dict(json.loads(text))
            write_report(job, result, inputs, layout)
    except Exception as exc:  # reading the job back failed: say why, the job stays done
        logger.exception("report of %s failed", job_id)
        shutil.rmtree(tmp, ignore_errors=True)
        with contextlib.suppress(OSError):
            error_file.write_text(f"{type(exc).__name__}: {exc}")


def forked_drawing(arguments: tuple[Path, Path, str, int], work: Path, service_pid: int) -> None:
    """Body of a drawing process: its own session, the job's log, ``work`` as TMPDIR."""
    os.setsid()
    die_with_pool_owner(service_pid)
    os.nice(JOB_NICENESS)
    _, data_dir, job_id, _ = arguments
    log = os.open(DataLayout(data_dir).log(job_id), os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(log, 2)
    os.close(log)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    os.environ["TMPDIR"] = str(work)
    tempfile.tempdir = None
    draw_job_report(*arguments)
    sys.exit(0)
