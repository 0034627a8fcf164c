"""Keeping the data folder bounded: job removal, retention, orphaned files, disk room.

Files of a job besides its rows are :meth:`fmuid.jobs.layout.DataLayout.job_files`. Blobs
(uploads by content hash) are shared between jobs and removed when no job refers to them any
more.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import time
from pathlib import Path

from fmuid.jobs.store import JobStore, retried

logger = logging.getLogger(__name__)

BLOB_GRACE_S = 120.0
"""An unreferenced blob younger than this may belong to a submission under way: kept."""


def remove_paths(paths: list[Path]) -> None:
    """Remove files and folders, ignoring those already gone."""
    for path in paths:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)


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


def delete_jobs(store: JobStore, job_ids: list[str]) -> list[str]:
    """Remove finished jobs: their rows, result, report, log and the blobs no job needs.

    Returns
    -------
    list of str
        The ids removed (a job not finished is left alone).

    """
    removed = _delete_rows(store, job_ids)
    for job_id in removed:
        remove_paths(store.layout.job_files(job_id))
    if removed:
        remove_unused_blobs(store)
    return removed


def expired_jobs(store: JobStore, max_age_s: float) -> list[str]:
    """Return the ids of jobs that finished more than ``max_age_s`` seconds ago."""
    rows = store.connection().execute(
        "SELECT id FROM jobs WHERE status IN ('done', 'failed', 'cancelled') AND finished < ?",
        (time.time() - max_age_s,),
    )
    return [row[0] for row in rows]


def remove_unused_blobs(store: JobStore) -> None:
    """Remove blobs (and staged FMU links) no job refers to, except very recent ones."""
    used = set()
    for fmu, datasets in store.connection().execute("SELECT fmu_sha256, datasets FROM jobs"):
        used.add(fmu)
        used.update(d["sha256"] for d in json.loads(datasets))
    now = time.time()
    for blob in store.layout.blobs.iterdir():
        if blob.name in used:
            continue
        try:
            if now - blob.stat().st_mtime < BLOB_GRACE_S:
                continue
        except FileNotFoundError:
            continue
        blob.unlink(missing_ok=True)
        shutil.rmtree(store.layout.fmu_dir(blob.name), ignore_errors=True)


def remove_orphans(store: JobStore, alive: set[str]) -> None:
    """Remove job files whose job is gone, and work folders of jobs without a live process.

    ``alive`` holds the jobs whose process runs; the work folder ``<id>.report`` of a report
    being drawn (its marker ``reports/<id>.tmp`` exists) is kept too.
    """
    layout = store.layout
    ids = {row[0]: row[1] for row in store.connection().execute("SELECT id, status FROM jobs")}
    for folder in (layout.reports, layout.logs):
        for path in folder.glob("*") if folder.is_dir() else []:
            if path.name.split(".")[0] not in ids:
                remove_paths([path])
    checkpoints = layout.checkpoints
    for path in checkpoints.iterdir() if checkpoints.is_dir() else []:
        if ids.get(path.name) not in ("queued", "running"):
            remove_paths([path])
    tmp_root = layout.job_tmp_root
    by_name = {layout.job_tmp_name(job_id): job_id for job_id in ids}
    kept = {layout.job_tmp_name(job_id) for job_id in alive}
    for path in tmp_root.iterdir() if tmp_root.is_dir() else []:
        name, _, suffix = path.name.partition(".")
        job_id = by_name.get(name)
        drawing = suffix and job_id is not None and layout.report_marker(job_id).is_dir()
        if (suffix or name not in kept) and not drawing:
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
