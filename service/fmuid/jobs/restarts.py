"""After a lost process or a restart: jobs back in the queue, and the lease of the store.

A job whose process was lost through no fault of its own (the service stopped, a warm server
crashed) is queued again, up to :data:`MAX_ATTEMPTS` starts, so that an input that kills the
service cannot loop forever. One live service uses a job store at a time: it holds the lease
and renews it every few seconds.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from fmuid.jobs.store import Job, JobStore, StoreError, retried

MAX_ATTEMPTS = 3
"""A job interrupted by this many service restarts is failed instead of queued again."""
LEASE_S = 15.0
"""A service renews its lease every few seconds; one older than this belongs to a dead one."""


class LeaseHeld(StoreError):
    """Another live service uses the same job store."""


@retried
def requeue(store: JobStore, job_id: str, reason: str) -> bool:
    """Put a running job whose process was lost through no fault of its own back in the queue.

    A job started :data:`MAX_ATTEMPTS` times already is failed with ``reason`` instead.
    Returns whether the job was queued again.
    """
    with store.transaction() as conn:
        cur = conn.execute(
            "UPDATE jobs SET status = 'queued', pid = NULL, started = NULL"
            " WHERE id = ? AND status = 'running' AND attempts < ?",
            (job_id, MAX_ATTEMPTS),
        )
        if cur.rowcount:
            return True
        conn.execute(
            "UPDATE jobs SET status = 'failed', error = ?, finished = ?, pid = NULL"
            " WHERE id = ? AND status = 'running'",
            (f"{reason} ({MAX_ATTEMPTS} attempts); not retried", time.time(), job_id),
        )
    return False


@retried
def recover(store: JobStore) -> list[Job]:
    """Put jobs left running by a stopped service back in the queue.

    A job that has already been started :data:`MAX_ATTEMPTS` times is failed with the
    reason instead.

    Returns
    -------
    list of Job
        The jobs as they were found (status ``running``), with the pid of their process.

    """
    with store.transaction() as conn:
        rows = conn.execute("SELECT * FROM jobs WHERE status = 'running'").fetchall()
        conn.execute(
            "UPDATE jobs SET status = 'failed', finished = ?, pid = NULL, error ="
            " 'interrupted by a restart of the service ' || attempts || ' times; not retried'"
            " WHERE status = 'running' AND attempts >= ?",
            (time.time(), MAX_ATTEMPTS),
        )
        conn.execute(
            "UPDATE jobs SET status = 'queued', pid = NULL, started = NULL WHERE status = 'running'"
        )
    return [Job.from_row(r) for r in rows]


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
def renew_lease(store: JobStore) -> bool:
    """Say this service is still alive; return whether it still holds the lease."""
    with store.transaction() as conn:
        cur = conn.execute(
            "UPDATE lease SET heartbeat = ? WHERE id = 1 AND pid = ?", (time.time(), os.getpid())
        )
    return cur.rowcount > 0


@retried
def release_lease(store: JobStore) -> None:
    """Give the store up (a clean stop): the next service need not wait."""
    with store.transaction() as conn:
        conn.execute("DELETE FROM lease WHERE id = 1 AND pid = ?", (os.getpid(),))
