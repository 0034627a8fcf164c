"""One owner per data folder: an exclusive ``flock`` held for the service's whole life.

The lease in the store (:mod:`fmuid.jobs.restarts`) ages: a service frozen past its lifetime
(SIGSTOP, a paused container, a suspended machine) would lose it to a second one while still
believing it owns the store. A lock of the operating system does not age: the kernel holds it
for the open file until the process dies, frozen or not, so a second service on the same data
folder cannot start while the first lives, however long it sleeps. The file is opened
close-on-exec, so no process the service starts keeps the lock after the service is gone.
"""

from __future__ import annotations

import fcntl
import logging
import os
from pathlib import Path

from fmuid.jobs.store import StoreError

logger = logging.getLogger(__name__)

LOCK_NAME = "service.lock"
"""The lock file in the data folder; it holds the pid of the owner (for the message only)."""


class StoreInUse(StoreError):
    """Another live service holds the data folder."""


class OwnerLock:
    """The exclusive lock of a data folder (and of the database, when it lies elsewhere).

    Parameters
    ----------
    data_dir
        The data folder.
    db_path
        The job store's database: locked too when it is not in ``data_dir``.

    """

    def __init__(self, data_dir: Path, db_path: Path):
        self.paths = [data_dir / LOCK_NAME]
        if db_path.parent != data_dir:
            self.paths.append(db_path.with_name(db_path.name + ".lock"))
        self._fds: list[int] = []

    @property
    def held(self) -> bool:
        """Whether this process holds the lock."""
        return bool(self._fds)

    def acquire(self) -> None:
        """Take the lock without waiting.

        Raises
        ------
        StoreInUse
            Naming the lock file and the pid of the service that holds it.

        """
        if self._fds:
            return
        for path in self.paths:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
                os.close(fd)
                self.release()
                raise StoreInUse(
                    f"{path.parent} is in use by another fmuid service (process {holder} holds"
                    f" {path}); stop it, or give this service its own FMUID_DATA_DIR"
                ) from None
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            self._fds.append(fd)

    def release(self) -> None:
        """Give the lock up (closing the file releases it)."""
        for fd in self._fds:
            os.close(fd)
        self._fds.clear()
