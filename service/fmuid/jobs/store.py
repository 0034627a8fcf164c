"""The job store: jobs and results in SQLite, uploaded files on disk by content hash.

One SQLite file (WAL mode) holds the jobs table and the results; every thread and process opens
its own connection and keeps transactions short, so the API process, its supervisor thread and
the job processes can share the file. Every commit is synced to disk (``synchronous=FULL``: an
accepted job survives a power cut, not only a crash of the service; the cost is one fsync of the
log per write, well under the rate of jobs), and a clean stop checkpoints the log into the main
file (:meth:`JobStore.checkpoint`), so that a stopped store is one self-contained file.
Uploaded FMUs and CSV files live in ``<data_dir>/blobs/<sha256>``, written through a temporary
file and ``os.replace`` so that a crash never leaves half a file under a final name. Where each
file lives is :class:`fmuid.jobs.layout.DataLayout`; putting jobs back in the queue after a lost
process or a restart is :mod:`fmuid.jobs.restarts`.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import sqlite3
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import ParamSpec, TypeVar, cast

from fmuid.jobs.layout import DataLayout
from fmuid.jobs.records import FINAL_STATUSES, STATUSES, Dataset, Job, Kind

__all__ = ["FINAL_STATUSES", "Dataset", "Job", "JobStore", "QueueFull", "StoreError", "retried"]

logger = logging.getLogger(__name__)

WRITE_ATTEMPTS = 4
"""A write that fails this many times (locked, I/O error, disk full) raises :class:`StoreError`."""
RESERVE_BYTES = 4 * 1024 * 1024
"""Size of ``<data_dir>/reserve``: given back to the file system when the disk is full, so that
the store can still record why jobs failed."""

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY,
    kind TEXT NOT NULL,
    status TEXT NOT NULL,
    created REAL NOT NULL,
    started REAL,
    finished REAL,
    progress_done INTEGER NOT NULL DEFAULT 0,
    progress_total INTEGER NOT NULL DEFAULT 0,
    progress_stage TEXT NOT NULL DEFAULT '',
    progress_detail TEXT NOT NULL DEFAULT '',
    error TEXT,
    fmu_sha256 TEXT NOT NULL,
    model_name TEXT NOT NULL,
    spec TEXT NOT NULL,
    datasets TEXT NOT NULL,
    attempts INTEGER NOT NULL DEFAULT 0,
    pid INTEGER,
    space TEXT
);
CREATE INDEX IF NOT EXISTS jobs_status_created ON jobs (status, created);
CREATE TABLE IF NOT EXISTS results (
    job_id TEXT PRIMARY KEY REFERENCES jobs (id),
    json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS probe (id INTEGER PRIMARY KEY CHECK (id = 1), time REAL NOT NULL);
CREATE TABLE IF NOT EXISTS lease (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    pid INTEGER NOT NULL,
    heartbeat REAL NOT NULL
);
"""

_ADDED = {"progress_detail": "TEXT NOT NULL DEFAULT ''", "space": "TEXT"}
"""Columns added since the first version (designs stored before ``space`` keep it as a dataset)."""

P = ParamSpec("P")
R = TypeVar("R")


class StoreError(RuntimeError):
    """The job store could not be read or written (disk full, I/O error, damaged file)."""


class QueueFull(RuntimeError):
    """The queue holds ``max_queued`` jobs already."""


def retried(method: Callable[P, R]) -> Callable[P, R]:
    """Retry a write of the store on transient SQLite errors; raise :class:`StoreError` at last.

    Before retrying a write that failed for a full disk, the store gives back its reserve file.
    """

    @functools.wraps(method)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        store = cast(JobStore, args[0])
        for attempt in range(WRITE_ATTEMPTS):
            try:
                return method(*args, **kwargs)
            except sqlite3.OperationalError as exc:  # locked, I/O error, disk full
                error = exc
                logger.warning("store %s failed (%s), attempt %d", method.__name__, exc, attempt)
                if "full" in str(exc):
                    store.release_reserve()
                if attempt + 1 < WRITE_ATTEMPTS:
                    time.sleep(0.05 * 4**attempt)
            except sqlite3.DatabaseError as exc:  # a damaged file: trying again will not help
                raise StoreError(f"job store {store.db_path}: {exc}") from exc
        raise StoreError(
            f"job store {store.db_path}: {method.__name__} failed {WRITE_ATTEMPTS} times: {error}"
        ) from error

    return wrapper


class JobStore:
    """Jobs, results and blobs under one data folder.

    Parameters
    ----------
    db_path
        The SQLite file; created with its tables when missing.
    data_dir
        The data folder (:class:`~fmuid.jobs.layout.DataLayout`); its ``blobs/`` and
        ``tmp/`` are created when missing.
    max_queued
        :meth:`create` raises :class:`QueueFull` when this many jobs are queued already.

    """

    def __init__(self, db_path: Path, data_dir: Path, max_queued: int | None = None):
        self.db_path = Path(db_path)
        self.max_queued = max_queued
        self.layout = DataLayout(Path(data_dir))
        self.layout.blobs.mkdir(parents=True, exist_ok=True)
        self.layout.uploads.mkdir(exist_ok=True)
        self.db_path.parent.mkdir(parents=True, exist_ok=True)
        self._local = threading.local()
        self.reserve = self.layout.reserve
        try:
            self._connection().executescript(_SCHEMA)
            self._add_missing_columns()
        except sqlite3.DatabaseError as exc:  # the service still starts, and says so in health
            logger.error("job store %s cannot be opened: %s", self.db_path, exc)
        self.keep_reserve()

    def _add_missing_columns(self) -> None:
        """Give a store made by an earlier version the columns added since (:data:`_ADDED`)."""
        conn = self._connection()
        columns = {row[1] for row in conn.execute("PRAGMA table_info(jobs)")}
        for name in _ADDED.keys() - columns:
            try:
                conn.execute(f"ALTER TABLE jobs ADD COLUMN {name} {_ADDED[name]}")
            except sqlite3.OperationalError as exc:  # another process added it meanwhile
                if "duplicate column" not in str(exc):
                    raise

    # -- connections -------------------------------------------------------------------------

    def _connection(self) -> sqlite3.Connection:
        conn: sqlite3.Connection | None = getattr(self._local, "conn", None)
        if conn is None or getattr(self._local, "pid", None) != os.getpid():
            conn = sqlite3.connect(self.db_path, timeout=30.0, isolation_level=None)
            conn.row_factory = sqlite3.Row
            conn.execute("PRAGMA journal_mode=WAL")
            conn.execute("PRAGMA synchronous=FULL")
            conn.execute("PRAGMA foreign_keys=ON")
            self._local.conn = conn
            self._local.pid = os.getpid()
        return conn

    def checkpoint(self) -> None:
        """Copy the write-ahead log into the main file and empty it (on a clean stop)."""
        busy, _, _ = self._connection().execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchone()
        if busy:
            logger.warning("job store %s: the log could not be checkpointed (busy)", self.db_path)

    def keep_reserve(self) -> None:
        """Create the reserve file when it is missing (and the disk has room for it)."""
        if self.reserve.exists():
            return
        try:
            with open(self.reserve.with_suffix(".tmp"), "wb") as stream:
                stream.write(b"\0" * RESERVE_BYTES)
            os.replace(self.reserve.with_suffix(".tmp"), self.reserve)
        except OSError as exc:
            logger.warning("no room for the reserve file %s: %s", self.reserve, exc)
            self.reserve.with_suffix(".tmp").unlink(missing_ok=True)

    def release_reserve(self) -> None:
        """Delete the reserve file, giving its space back for the store's own writes."""
        if self.reserve.exists():
            logger.warning("disk full: releasing %s", self.reserve)
            self.reserve.unlink(missing_ok=True)

    def connection(self) -> sqlite3.Connection:
        """Return this thread's connection (for checks; writes go through the store's methods)."""
        return self._connection()

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """Run the block in one write transaction, rolled back when it (or its commit) fails."""
        conn = self._connection()
        conn.execute("BEGIN IMMEDIATE")
        try:
            yield conn
            conn.execute("COMMIT")
        except BaseException:
            if conn.in_transaction:
                conn.execute("ROLLBACK")
            raise

    # -- blobs -------------------------------------------------------------------------------

    def add_file(self, path: Path) -> str:
        """Move a file into the blob folder under its SHA-256 (hex) and return the hash.

        ``path`` must be on the same file system as the data folder (e.g. in :meth:`tmp_dir`);
        the rename is atomic, so a crash never leaves a partial blob, and equal uploads share
        one blob.
        """
        digest = hashlib.sha256()
        with open(path, "rb") as stream:
            while chunk := stream.read(1 << 20):
                digest.update(chunk)
        sha = digest.hexdigest()
        os.replace(path, self.layout.blob(sha))
        return sha

    def tmp_dir(self) -> Path:
        """Return the folder for uploads being checked (beside the blobs, same file system)."""
        return self.layout.uploads

    def blob_path(self, sha256: str) -> Path:
        """Return the file of a blob (which exists once :meth:`add_file` returned its hash)."""
        return self.layout.blob(sha256)

    # -- jobs --------------------------------------------------------------------------------

    @retried
    def create(
        self,
        kind: Kind,
        spec: str,
        fmu_sha256: str,
        model_name: str,
        datasets: list[Dataset],
        space: str | None = None,
    ) -> Job:
        """Insert a queued job and return it (``space``: a design's experiment space, JSON text).

        Raises
        ------
        QueueFull
            When :attr:`max_queued` jobs are queued already.

        """
        job_id = str(uuid.uuid4())
        with self.transaction() as conn:
            if self.max_queued is not None:
                (queued,) = conn.execute(
                    "SELECT COUNT(*) FROM jobs WHERE status = 'queued'"
                ).fetchone()
                if queued >= self.max_queued:
                    raise QueueFull(f"the queue is full: {queued} jobs wait (FMUID_QUEUE_LIMIT)")
            conn.execute(
                "INSERT INTO jobs (id, kind, status, created, fmu_sha256, model_name, spec,"
                " datasets, space) VALUES (?, ?, 'queued', ?, ?, ?, ?, ?, ?)",
                (
                    job_id,
                    kind,
                    time.time(),
                    fmu_sha256,
                    model_name,
                    spec,
                    json.dumps([{"name": d.name, "sha256": d.sha256} for d in datasets]),
                    space,
                ),
            )
        job = self.get(job_id)
        assert job is not None
        return job

    def get(self, job_id: str) -> Job | None:
        """Return a job, or ``None`` when there is no job with that id."""
        row = self._connection().execute("SELECT * FROM jobs WHERE id = ?", (job_id,)).fetchone()
        return Job.from_row(row) if row else None

    def list_jobs(self, limit: int = 100, offset: int = 0) -> list[Job]:
        """Return jobs, newest first."""
        rows = self._connection().execute(
            "SELECT * FROM jobs ORDER BY created DESC, rowid DESC LIMIT ? OFFSET ?",
            (limit, offset),
        )
        return [Job.from_row(r) for r in rows]

    def counts(self) -> dict[str, int]:
        """Return the number of jobs per status (every status present, zeros included)."""
        rows = self._connection().execute("SELECT status, COUNT(*) FROM jobs GROUP BY status")
        counts: dict[str, int] = dict.fromkeys(STATUSES, 0)
        counts.update({status: n for status, n in rows})
        return counts

    def running(self) -> list[Job]:
        """Return the jobs marked running."""
        rows = self._connection().execute("SELECT * FROM jobs WHERE status = 'running'")
        return [Job.from_row(r) for r in rows]

    @retried
    def claim_next(self, owner: int | None = None) -> Job | None:
        """Mark the oldest queued job running (one more attempt) and return it, or ``None``.

        With ``owner`` (a pid), only while that process holds the store's lease: a service that
        lost it (:mod:`fmuid.jobs.restarts`) claims nothing, in the same transaction.
        """
        fence = "" if owner is None else " AND EXISTS (SELECT 1 FROM lease WHERE pid = ?)"
        with self.transaction() as conn:
            row = conn.execute(
                "UPDATE jobs SET status = 'running', started = ?, attempts = attempts + 1,"
                " error = NULL, progress_done = 0, progress_total = 0, progress_stage = '',"
                " progress_detail = ''"
                " WHERE id = (SELECT id FROM jobs WHERE status = 'queued'"
                f" ORDER BY created, rowid LIMIT 1){fence} RETURNING *",
                (time.time(),) if owner is None else (time.time(), owner),
            ).fetchone()
        return Job.from_row(row) if row else None

    @retried
    def set_pid(self, job_id: str, pid: int | None) -> None:
        """Record the process that runs a job."""
        with self.transaction() as conn:
            conn.execute("UPDATE jobs SET pid = ? WHERE id = ?", (pid, job_id))

    @retried
    def set_progress(
        self, job_id: str, done: int, total: int, stage: str, detail: str = ""
    ) -> None:
        """Record a progress event of a running job (``detail``: what it is doing, for people)."""
        with self.transaction() as conn:
            conn.execute(
                "UPDATE jobs SET progress_done = ?, progress_total = ?, progress_stage = ?,"
                " progress_detail = ? WHERE id = ? AND status = 'running'",
                (done, total, stage, detail, job_id),
            )

    @retried
    def finish(self, job_id: str, result_json: str) -> bool:
        """Store the result (JSON text) of a running job and mark it done.

        Returns
        -------
        bool
            ``False`` when the job was no longer running (cancelled meanwhile): nothing stored.

        """
        with self.transaction() as conn:
            cur = conn.execute(
                "UPDATE jobs SET status = 'done', finished = ?, pid = NULL,"
                " progress_done = MAX(progress_done, progress_total)"
                " WHERE id = ? AND status = 'running'",
                (time.time(), job_id),
            )
            if cur.rowcount == 0:
                return False
            conn.execute(
                "INSERT OR REPLACE INTO results (job_id, json) VALUES (?, ?)", (job_id, result_json)
            )
        return True

    def fail(self, job_id: str, error: str) -> bool:
        """Mark a queued or running job failed with the reason; ``False`` if it was final."""
        return self._finalise(job_id, "failed", error)

    def cancel(self, job_id: str) -> bool:
        """Mark a queued or running job cancelled; ``False`` if it was final already."""
        return self._finalise(job_id, "cancelled", "cancelled by request")

    @retried
    def _finalise(self, job_id: str, status: str, error: str) -> bool:
        with self.transaction() as conn:
            cur = conn.execute(
                "UPDATE jobs SET status = ?, error = ?, finished = ?, pid = NULL"
                " WHERE id = ? AND status IN ('queued', 'running')",
                (status, error, time.time(), job_id),
            )
        return cur.rowcount > 0

    def result(self, job_id: str) -> str | None:
        """Return the result JSON text of a done job, or ``None``."""
        row = (
            self._connection()
            .execute("SELECT json FROM results WHERE job_id = ?", (job_id,))
            .fetchone()
        )
        return row[0] if row else None
