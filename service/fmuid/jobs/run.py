"""Run one job in this process: ``python -m fmuid.jobs.run JOB_ID --db ... --data-dir ...``.

The supervisor (:mod:`fmuid.jobs.worker`) starts one such process per job in a new session (with
the bootstrap of :mod:`fmuid.jobs.proc`, which makes it die with the service), so that a crash, a
hang or runaway memory of the FMU hits only this process (and the pool workers the engine starts
from it), which the supervisor can kill as a group. This process limits its own address space,
enforces its own time limit (it records the failure and kills its group), loads the job's inputs
from the store, runs the engine of the job's kind (its runner, :mod:`fmuid.jobs.kinds`), reports
progress at most every :data:`PROGRESS_INTERVAL_S` and stores the result (or the reason it
failed). The HTML report is drawn later, on its first request (:mod:`fmuid.jobs.draw`).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import math
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Iterator
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from fmuid.errors import FmuError, FmuidError
from fmuid.intake.inputs import load_job_inputs
from fmuid.jobs.crash import FMI_VERSION_LINE, STORE_FAILED_EXIT, crash_message, memory_message
from fmuid.jobs.health import free_space_problem
from fmuid.jobs.kinds import RunContext, runner
from fmuid.jobs.reaper import end_tree, end_tree_on_parent_death
from fmuid.jobs.store import Job, JobStore, StoreError
from fmuid.model.fmu import model_of_file
from fmuid.model.world import open_registry
from fmuid.processes import become_subreaper, kill_group, limit_memory
from fmuid.progress import Progress

logger = logging.getLogger(__name__)

PROGRESS_INTERVAL_S = 0.5
ALARM_GRACE_S = 10
"""The kernel's ``SIGALRM`` ends the job this long after its time limit if nothing else did."""


def enforce_time_limit(store: JobStore, job_id: str, timeout_s: float) -> None:
    """End this job (and its process group) ``timeout_s`` seconds from now, whatever it does.

    A watchdog thread records the failure and kills the group; should it be stuck, ``SIGALRM``
    (its default action ends the process, even inside native code) follows
    :data:`ALARM_GRACE_S` later.
    """

    def expire() -> None:
        try:
            store.fail(job_id, f"exceeded the time limit of {timeout_s:g} s")
        finally:
            end_tree(os.getpid())
            kill_group(os.getpgrp())

    watchdog = threading.Timer(timeout_s, expire)
    watchdog.daemon = True
    watchdog.start()
    signal.signal(signal.SIGALRM, signal.SIG_DFL)
    signal.alarm(math.ceil(timeout_s) + ALARM_GRACE_S)


class ProgressWriter:
    """Progress callback that writes to the store at most every ``interval`` seconds.

    Each write carries the event's detail (what the job is doing). Events of open-ended stages
    (``total`` 0: the trust-region refinement, whose evaluations are not known ahead) keep the
    last counted stage's ``done`` and ``total``, so that ``done`` never exceeds ``total`` over
    HTTP, and say in the detail what the stage is doing and how far it has come.
    """

    def __init__(self, store: JobStore, job_id: str, interval: float = PROGRESS_INTERVAL_S):
        self.store = store
        self.job_id = job_id
        self.interval = interval
        self._last = 0.0
        self._counted = Progress("", 0, 0)

    def __call__(self, event: Progress) -> None:
        """Record ``event`` unless one was recorded less than ``interval`` ago."""
        counted = self._counted
        if event.total > 0:
            self._counted = counted = event
            detail = event.detail
        else:
            detail = f"{event.stage}: {event.done} evaluations" + (
                f", {event.detail}" if event.detail else ""
            )
        now = time.monotonic()
        if now - self._last >= self.interval or (event.total and event.done >= event.total):
            self._last = now
            try:
                self.store.set_progress(
                    self.job_id, counted.done, counted.total, counted.stage or event.stage, detail
                )
            except StoreError as exc:  # progress can wait; the outcome is written with retries
                logger.warning("progress of job %s not recorded: %s", self.job_id, exc)


def run_job(
    store: JobStore, job: Job, memory_mb: int, dask: str | None, min_free_bytes: int = 0
) -> int:
    """Run ``job`` and record its outcome; return the process exit status (0 when done).

    The result is stored only while the disk of the data folder keeps ``min_free_bytes`` free
    (the level below which the API takes no new job); under it the job fails, saying so.
    """
    progress = ProgressWriter(store, job.id)
    # a design keeps its finished evaluations here until the job has an outcome: a job
    # re-run after a restart of the service resumes from them
    checkpoint = store.layout.checkpoint(job.id)
    with (
        tempfile.TemporaryDirectory(prefix=f"fmuid-job-{job.id[:8]}-") as tmp,
        _removed_after(checkpoint),
    ):
        try:
            inputs = load_job_inputs(store, job, Path(tmp), on_staged=_log_fmi_version)
            result = runner(job.kind).run(inputs, RunContext(progress, dask, checkpoint))
            result_json = json.dumps(result.to_dict(), allow_nan=False)
        except FmuidError as exc:
            store.fail(job.id, str(exc))
            return 1
        except MemoryError:
            store.fail(job.id, memory_message(memory_mb))
            return 1
        except BrokenProcessPool:
            sys.stderr.flush()
            log = _read_log()
            store.fail(
                job.id,
                crash_message(log, memory_mb) or "a worker process of the job died unexpectedly",
            )
            return 1
        except StoreError as exc:
            store.fail(job.id, f"the job store failed while the job ran: {exc}")
            return 1
        except Exception as exc:
            traceback.print_exc()
            store.fail(job.id, f"internal error: {type(exc).__name__}: {exc}")
            return 1
        short = free_space_problem(store.layout.root, min_free_bytes)
        if short:
            store.fail(job.id, f"the job store has no room for the result: {short}")
            return 1
        try:
            stored = store.finish(job.id, result_json)
        except StoreError as exc:
            store.fail(job.id, f"could not store the result: {exc}")
            return 1
        if not stored:
            logger.info("job %s was cancelled before it finished", job.id)
    return 0


@contextlib.contextmanager
def _removed_after(folder: Path) -> Iterator[None]:
    """Remove ``folder`` when the block ends normally (the job has its outcome).

    Not when the process is killed or an exception escapes: the next run resumes from it.
    """
    yield
    shutil.rmtree(folder, ignore_errors=True)


def _log_fmi_version(fmu: Path) -> None:
    """Write the FMU's FMI version to stderr (the job log), for :mod:`fmuid.jobs.crash`.

    The FMU is parsed here, once for the job: the stage finds this model by the file.
    """
    try:
        version = model_of_file(fmu).fmi_version
    except FmuError:  # the stage says what is wrong with it
        return
    sys.stderr.write(f"{FMI_VERSION_LINE}{version}\n")
    sys.stderr.flush()


def _read_log() -> str:
    """Return what this process's stderr file holds so far ('' when stderr is not a file)."""
    try:
        return Path(f"/proc/self/fd/{sys.stderr.fileno()}").read_text(errors="replace")
    except OSError:
        return ""


def main(argv: list[str] | None = None) -> int:
    """Entry point of a job process."""
    parser = argparse.ArgumentParser(prog="python -m fmuid.jobs.run")
    parser.add_argument("job_id")
    parser.add_argument("--db", type=Path, required=True)
    parser.add_argument("--data-dir", type=Path, required=True)
    parser.add_argument("--memory-mb", type=int, required=True)
    parser.add_argument("--timeout-s", type=float, required=True)
    parser.add_argument("--dask-scheduler", default=None)
    parser.add_argument("--min-free-bytes", type=int, default=0)
    parser.add_argument("--service-pid", type=int, default=None)
    args = parser.parse_args(argv)
    limit_memory(args.memory_mb)
    become_subreaper()  # whatever the job starts stays below it (fmuid.jobs.reaper)
    end_tree_on_parent_death(args.service_pid)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    logger.info("job %s in process %d, started by %d", args.job_id, os.getpid(), os.getppid())
    store = JobStore(args.db, args.data_dir)
    job = store.get(args.job_id)
    if job is None or job.status != "running":
        logger.warning("job %s is not running; nothing to do", args.job_id)
        return 0
    enforce_time_limit(store, job.id, args.timeout_s)
    try:
        with open_registry():
            return run_job(store, job, args.memory_mb, args.dask_scheduler, args.min_free_bytes)
    except StoreError:
        logger.exception("job %s could not record its outcome", job.id)
        return STORE_FAILED_EXIT
    finally:
        end_tree(os.getpid())


if __name__ == "__main__":
    sys.exit(main())
