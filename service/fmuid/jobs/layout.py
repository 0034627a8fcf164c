"""The data folder of the service: where every file of the job store lives, written down once.

::

    <data_dir>/
        jobs.sqlite            the job store (default of FMUID_DB_PATH; see fmuid.settings)
        reserve                space given back when the disk is full (JobStore)
        blobs/<sha256>         uploaded FMUs and CSV files, by content hash
        tmp/                   uploads being checked (same file system as blobs/)
        fmus/<sha256>/<model>.fmu   a stable path (a link) of an FMU blob for dask workers
        logs/<id>.log          a job's stderr, and its report drawing's
        reports/<id>/          a job's drawn HTML report
        reports/<id>.tmp/      the "being drawn" marker and work folder
        reports/<id>.error     why a report could not be drawn
        checkpoints/<id>/      a design's finished evaluations, kept across restarts
    <short tmp>/fmuid-<key>/<id12>/  a job's TMPDIR (outside the data folder, see job_tmp_root)
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from fmuid.errors import FmuidError

__all__ = ["DataLayout", "short_tmp"]

SOCKET_PATH_MAX = 107
"""Longest path of a Unix socket (``sun_path`` holds 108 bytes with the final NUL)."""
SOCKET_TAIL = len("/pymp-xxxxxxxx/listener-xxxxxxxx")
"""What multiprocessing adds to ``TMPDIR`` for the socket of a forkserver."""
JOB_TMP_TAIL = len("/fmuid-xxxxxxxx/xxxxxxxxxxxx.r")
"""What the layout adds to the temporary folder for a job's (or a drawing's) ``TMPDIR``."""
FALLBACK_TMP = ("/tmp", "/var/tmp", "/dev/shm")


def short_tmp() -> Path:
    """Return a temporary folder short enough for the sockets of the jobs' process pools.

    The system's (``TMPDIR``) when a job's forkserver socket fits under it, else the first of
    :data:`FALLBACK_TMP` that exists and is writable.

    Raises
    ------
    FmuidError
        When none fits: the service refuses to start, naming ``TMPDIR``.

    """
    system = tempfile.gettempdir()
    budget = SOCKET_PATH_MAX - SOCKET_TAIL - JOB_TMP_TAIL
    for candidate in (system, *FALLBACK_TMP):
        fits = len(os.fsencode(candidate)) <= budget
        if fits and os.path.isdir(candidate) and os.access(candidate, os.W_OK | os.X_OK):
            return Path(candidate)
    raise FmuidError(
        f"TMPDIR {system!r} is longer than {budget} bytes, too long for the Unix sockets of job"
        f" processes, and none of {', '.join(FALLBACK_TMP)} is writable: set a shorter TMPDIR"
    )


def fit_own_tmp() -> None:
    """Give this process a temporary folder its own forkserver's socket fits under.

    When ``TMPDIR`` is too long for it, :func:`short_tmp` becomes this process's temporary
    folder (``tempfile.tempdir``), so that the service's warm server can start.
    """
    if len(os.fsencode(tempfile.gettempdir())) + SOCKET_TAIL > SOCKET_PATH_MAX:
        tempfile.tempdir = str(short_tmp())


@dataclass(frozen=True)
class DataLayout:
    """The paths of one data folder (nothing is created by asking for a path).

    Parameters
    ----------
    root
        The data folder (``FMUID_DATA_DIR``).

    """

    root: Path

    @property
    def blobs(self) -> Path:
        """Folder of the uploaded files, each named by its SHA-256 (hex)."""
        return self.root / "blobs"

    @property
    def uploads(self) -> Path:
        """Folder of uploads being checked (beside the blobs, so a rename moves them in)."""
        return self.root / "tmp"

    @property
    def reserve(self) -> Path:
        """File whose space the store gives back when the disk is full."""
        return self.root / "reserve"

    @property
    def logs(self) -> Path:
        """Folder of the jobs' logs."""
        return self.root / "logs"

    @property
    def reports(self) -> Path:
        """Folder of the drawn reports, their markers and error files."""
        return self.root / "reports"

    @property
    def checkpoints(self) -> Path:
        """Folder of the jobs' checkpoint folders."""
        return self.root / "checkpoints"

    def blob(self, sha256: str) -> Path:
        """Return the file of a blob."""
        return self.blobs / sha256

    def fmu_dir(self, sha256: str) -> Path:
        """Return the folder of the stable, named link of an FMU blob."""
        return self.root / "fmus" / sha256

    def log(self, job_id: str) -> Path:
        """Return a job's log file."""
        return self.logs / f"{job_id}.log"

    def report(self, job_id: str) -> Path:
        """Return the folder of a job's drawn report."""
        return self.reports / job_id

    def report_marker(self, job_id: str) -> Path:
        """Return the folder a report is drawn in; while it exists, a drawing is under way."""
        return self.reports / f"{job_id}.tmp"

    def report_error(self, job_id: str) -> Path:
        """Return the file saying why a job's report could not be drawn."""
        return self.reports / f"{job_id}.error"

    def checkpoint(self, job_id: str) -> Path:
        """Return the folder of a job's finished evaluations, kept across restarts."""
        return self.checkpoints / job_id

    @property
    def job_tmp_root(self) -> Path:
        """Folder of the jobs' temporary folders: one per data folder, in :func:`short_tmp`.

        It is not in the data folder, and its names are short, because the path of a Unix
        socket (multiprocessing's forkserver makes one in ``TMPDIR``) must be shorter than
        108 bytes.
        """
        key = hashlib.sha256(str(self.root).encode()).hexdigest()[:8]
        return short_tmp() / f"fmuid-{key}"

    @staticmethod
    def job_tmp_name(job_id: str) -> str:
        """Return the name of a job's temporary folder: 12 hexadecimal digits of its id."""
        return job_id.replace("-", "")[:12]

    def job_tmp(self, job_id: str) -> Path:
        """Return the ``TMPDIR`` of a job's processes (removed when the job process ends)."""
        return self.job_tmp_root / self.job_tmp_name(job_id)

    def report_work(self, job_id: str) -> Path:
        """Return the ``TMPDIR`` of the process drawing a job's report."""
        return self.job_tmp_root / f"{self.job_tmp_name(job_id)}.r"

    def job_files(self, job_id: str) -> list[Path]:
        """Return every file or folder a job may own (existing or not); blobs are shared."""
        return [
            self.report(job_id),
            self.report_error(job_id),
            self.report_marker(job_id),
            self.log(job_id),
            self.job_tmp(job_id),
            self.checkpoint(job_id),
        ]
