"""Keeping the data folder bounded: the service lease, job removal, retention, disk room.

Files of a job besides its rows: ``reports/<id>/`` (and ``<id>.error``, ``<id>.tmp``,
``<id>.pickle``), ``logs/<id>.log``, ``checkpoints/<id>/`` (a design's finished evaluations)
and :func:`job_tmp_dir` (the job processes' ``TMPDIR``: extracted FMU copies and work
folders). Blobs (uploads by content hash) are shared between jobs and removed when no job
refers to them any more.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import tempfile
import time
from pathlib import Path

from fmuid.jobs.store import JobStore, StoreError, retried

logger = logging.getLogger(__name__)

LEASE_S = 15.0
"""A service renews its lease every few seconds; one older than this belongs to a dead one."""
BLOB_GRACE_S = 120.0
"""An unreferenced blob younger than this may belong to a submission under way: kept."""


class LeaseHeld(StoreError):
    """Another live service uses the same job store."""


def job_files(data_dir: Path, job_id: str) -> list[Path]:
    """Return every file or folder a job may own in ``data_dir`` (existing or not)."""
    reports = data_dir / "reports"
    return [
        reports / job_id,
        reports / f"{job_id}.error",
        reports / f"{job_id}.tmp",
        data_dir / "logs" / f"{job_id}.log",
        job_tmp_dir(data_dir, job_id),
        checkpoint_dir(data_dir, job_id),
        reports / f"{job_id}.pickle",
    ]


def checkpoint_dir(data_dir: Path, job_id: str) -> Path:
    """Return the folder of a job's finished evaluations, kept across restarts of the service.

    The job process removes it once the job has an outcome; :func:`remove_orphans` sweeps the
    folders of jobs that are gone or finished (a job killed at its time limit).
    """
    return data_dir / "checkpoints" / job_id


def job_tmp_root(data_dir: Path) -> Path:
    """Return the folder of the jobs' temporary folders: one per data folder, in the system's.

    It is not in the data folder because the path of a Unix socket (multiprocessing's
    forkserver makes one in ``TMPDIR``) must be shorter than 108 bytes.
    """
    key = hashlib.sha256(str(data_dir).encode()).hexdigest()[:12]
    return Path(tempfile.gettempdir()) / f"fmuid-{key}"


def job_tmp_dir(data_dir: Path, job_id: str) -> Path:
    """Return the ``TMPDIR`` of a job's processes (removed when the job process ends)."""
    return job_tmp_root(data_dir) / job_id


def remove_paths(paths: list[Path]) -> None:
    """Remove files and folders, ignoring those already gone."""
    for path in paths:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)


# -- the lease -------------------------------------------------------------------------------


@retried
def take_lease(store: JobStore) -> None:
    """Make this process the service of ``store``.

    Raises
    ------
    LeaseHeld
        When another process that is still alive renewed the lease less than
        :data:`LEASE_S` ago.

    """
    with store.transaction() as conn:
        row = conn.execute("SELECT pid, heartbeat FROM lease WHERE id = 1").fetchone()
        if row is not None and row[0] != os.getpid():
            fresh = time.time() - row[1] < LEASE_S
            if fresh and Path(f"/proc/{row[0]}").exists():
                raise LeaseHeld(f"job store {store.db_path} is in use by service process {row[0]}")
        conn.execute(
            "INSERT OR REPLACE INTO lease (id, pid, heartbeat) VALUES (1, ?, ?)",
            (os.getpid(), time.time()),
        )


@retried
def renew_lease(store: JobStore) -> None:
    """Say this service is still alive."""
    with store.transaction() as conn:
        conn.execute(
            "UPDATE lease SET heartbeat = ? WHERE id = 1 AND pid = ?", (time.time(), os.getpid())
        )


@retried
def release_lease(store: JobStore) -> None:
    """Give the store up (a clean stop): the next service need not wait."""
    with store.transaction() as conn:
        conn.execute("DELETE FROM lease WHERE id = 1 AND pid = ?", (os.getpid(),))


# -- removing jobs ---------------------------------------------------------------------------


@retried
def _delete_rows(store: JobStore, job_ids: list[str]) -> list[str]:
    with store.transaction() as conn:
        removed = []
        for job_id in job_ids:
            conn.execute("DELETE FROM results WHERE job_id = ?", (job_id,))
            cur = conn.execute(
                "DELETE FROM jobs WHERE id = ? AND status IN ('done', 'failed', 'cancelled')",
                (job_id,),
            )
            if cur.rowcount:
                removed.append(job_id)
    return removed


def delete_jobs(store: JobStore, data_dir: Path, job_ids: list[str]) -> list[str]:
    """Remove finished jobs: their rows, result, report, log and the blobs no job needs.

    Returns
    -------
    list of str
        The ids removed (a job not finished is left alone).

    """
    removed = _delete_rows(store, job_ids)
    for job_id in removed:
        remove_paths(job_files(data_dir, job_id))
    if removed:
        remove_unused_blobs(store, data_dir)
    return removed


def expired_jobs(store: JobStore, max_age_s: float) -> list[str]:
    """Return the ids of jobs that finished more than ``max_age_s`` seconds ago."""
    rows = store.connection().execute(
        "SELECT id FROM jobs WHERE status IN ('done', 'failed', 'cancelled') AND finished < ?",
        (time.time() - max_age_s,),
    )
    return [row[0] for row in rows]


def remove_unused_blobs(store: JobStore, data_dir: Path) -> None:
    """Remove blobs (and staged FMU links) no job refers to, except very recent ones."""
    used = set()
    for fmu, datasets in store.connection().execute("SELECT fmu_sha256, datasets FROM jobs"):
        used.add(fmu)
        used.update(d["sha256"] for d in json.loads(datasets))
    now = time.time()
    for blob in store.blob_dir.iterdir():
        if blob.name in used:
            continue
        try:
            if now - blob.stat().st_mtime < BLOB_GRACE_S:
                continue
        except FileNotFoundError:
            continue
        blob.unlink(missing_ok=True)
        shutil.rmtree(data_dir / "fmus" / blob.name, ignore_errors=True)


def remove_orphans(store: JobStore, data_dir: Path, alive: set[str]) -> None:
    """Remove job files whose job is gone, and work folders of jobs without a live process.

    ``alive`` holds the jobs whose process runs; the work folder ``<id>.report`` of a report
    being drawn (its marker ``reports/<id>.tmp`` exists) is kept too.
    """
    ids = {row[0]: row[1] for row in store.connection().execute("SELECT id, status FROM jobs")}
    for folder in (data_dir / "reports", data_dir / "logs"):
        for path in folder.glob("*") if folder.is_dir() else []:
            if path.name.split(".")[0] not in ids:
                remove_paths([path])
    checkpoints = data_dir / "checkpoints"
    for path in checkpoints.iterdir() if checkpoints.is_dir() else []:
        if ids.get(path.name) not in ("queued", "running"):
            remove_paths([path])
    tmp_root = job_tmp_root(data_dir)
    for path in tmp_root.iterdir() if tmp_root.is_dir() else []:
        job_id = path.name.split(".")[0]
        if path.name not in alive and not (data_dir / "reports" / f"{job_id}.tmp").is_dir():
            remove_paths([path])


def data_usage(data_dir: Path) -> int:
    """Return the bytes the files under ``data_dir`` take (symbolic links not followed)."""
    total = 0
    stack = [data_dir]
    while stack:
        try:
            entries = list(os.scandir(stack.pop()))
        except OSError:
            continue
        for entry in entries:
            try:
                if entry.is_dir(follow_symlinks=False):
                    stack.append(Path(entry.path))
                elif entry.is_file(follow_symlinks=False):
                    total += entry.stat(follow_symlinks=False).st_blocks * 512
            except OSError:
                continue
    return total
