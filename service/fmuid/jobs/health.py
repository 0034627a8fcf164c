"""Is the job store sound? Integrity, a real write, and room on the disk, checked cheaply.

The full ``integrity_check`` runs once, at start; a damage found then stands until a restart.
The cheap checks that touch the database (``quick_check``, a real write, whether the file is still
the one opened at start) run at most every :data:`CHECK_INTERVAL_S` (health is polled often and
must answer at once); the answer in between is the last one.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import threading
import time
from pathlib import Path

from fmuid.jobs.housekeeping import data_usage

CHECK_INTERVAL_S = 5.0
BUSY_TIMEOUT_S = 0.05


def free_space_problem(data_dir: Path, min_free_bytes: int) -> str | None:
    """Return why the disk of ``data_dir`` has too little room for the store (None: it has room)."""
    try:
        free = shutil.disk_usage(data_dir).free
    except OSError as exc:
        return f"cannot read the free space of {data_dir}: {exc}"
    if free < min_free_bytes:
        return (
            f"only {free} bytes free on the disk of {data_dir}, less than"
            f" {min_free_bytes} (FMUID_MIN_FREE_BYTES)"
        )
    return None


class StoreHealth:
    """Checks of one job store and its data folder.

    Parameters
    ----------
    db_path
        The SQLite file.
    data_dir
        The data folder (blobs, reports, logs).
    min_free_bytes
        Free space below which the store is degraded [bytes].
    disk_quota_bytes
        Size of the data folder above which it is degraded [bytes]; 0: no quota.

    """

    def __init__(self, db_path: Path, data_dir: Path, min_free_bytes: int, disk_quota_bytes: int):
        self.db_path = db_path
        self.data_dir = data_dir
        self.min_free_bytes = min_free_bytes
        self.disk_quota_bytes = disk_quota_bytes
        self._lock = threading.Lock()
        self._checked = -CHECK_INTERVAL_S
        self._database: list[str] = []
        self._usage = 0
        self._file = self._identity()
        self._at_start = self._check_database("integrity_check")

    def problems(self) -> list[str]:
        """Return what is wrong with the store now (empty when it is sound)."""
        return self.database_problems() + self.room_problems()

    def database_problems(self) -> list[str]:
        """Return why the database cannot take a job (damaged, unwritable, removed)."""
        with self._lock:
            if time.monotonic() - self._checked >= CHECK_INTERVAL_S:
                self._database = self._check_file() or self._check_database("quick_check")
                self._usage = data_usage(self.data_dir) if self.disk_quota_bytes else 0
                self._checked = time.monotonic()
            return self._at_start + self._database

    def _identity(self) -> tuple[int, int] | None:
        try:
            found = os.stat(self.db_path)
        except OSError:
            return None
        return found.st_dev, found.st_ino

    def _check_file(self) -> list[str]:
        """Whether the database is still the file the service opened (not removed or replaced)."""
        if self._file is not None and self._identity() != self._file:
            return [
                f"the job store {self.db_path} was removed or replaced while the service ran;"
                " restart the service"
            ]
        return []

    def room_problems(self) -> list[str]:
        """Return why a new job would not fit on the disk (free space now, quota as last seen)."""
        found = []
        short = free_space_problem(self.data_dir, self.min_free_bytes)
        if short:
            found.append(short)
        if self.disk_quota_bytes and self._usage > self.disk_quota_bytes:
            found.append(
                f"the data folder takes {self._usage} bytes, more than its quota of"
                f" {self.disk_quota_bytes} (FMUID_DISK_QUOTA_BYTES)"
            )
        return found

    def _check_database(self, check: str) -> list[str]:
        try:
            conn = sqlite3.connect(self.db_path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        except sqlite3.Error as exc:
            return [f"cannot open the job store {self.db_path}: {exc}"]
        try:
            rows = [r[0] for r in conn.execute(f"PRAGMA {check}")]
            if rows != ["ok"]:
                return [f"the job store {self.db_path} is damaged: {'; '.join(rows[:3])}"]
            conn.execute("BEGIN IMMEDIATE")
            conn.execute("INSERT OR REPLACE INTO probe (id, time) VALUES (1, ?)", (time.time(),))
            conn.execute("COMMIT")
        except sqlite3.OperationalError as exc:
            if "locked" in str(exc) or "busy" in str(exc):
                return []  # a job is writing: the store works
            return [f"the job store {self.db_path} cannot be written: {exc}"]
        except sqlite3.Error as exc:
            return [f"the job store {self.db_path} is damaged: {exc}"]
        finally:
            conn.close()
        return []
