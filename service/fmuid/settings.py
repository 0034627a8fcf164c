"""Settings of the HTTP service and its job workers, read from ``FMUID_*`` environment variables.

The settings are read when the app is built (:func:`fmuid.api.create_app`), never at import, so
that tests and the job processes can each build their own.
"""

from __future__ import annotations

import os
from pathlib import Path

from pydantic import Field, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from fmuid.data.limits import FmuLimits, InputLimits

_INPUT = InputLimits()
_FMU = FmuLimits()


def default_data_dir() -> Path:
    """Return where jobs, uploads and results live unless ``FMUID_DATA_DIR`` says otherwise.

    ``$XDG_DATA_HOME/fmuid`` (usually ``~/.local/share/fmuid``) when a home directory exists,
    else ``./fmuid-data``.
    """
    xdg = os.environ.get("XDG_DATA_HOME")
    if xdg:
        return Path(xdg) / "fmuid"
    try:
        home = Path.home()
    except RuntimeError:
        return Path("fmuid-data").resolve()
    if not home.is_dir():
        return Path("fmuid-data").resolve()
    return home / ".local" / "share" / "fmuid"


class Settings(BaseSettings):
    """Configuration of ``fmuid serve``; every field is the environment variable ``FMUID_<NAME>``.

    Attributes
    ----------
    data_dir
        Folder holding the job database, uploaded files (by content hash), logs and reports.
    db_path
        SQLite file of the job store; default ``<data_dir>/jobs.sqlite``.
    api_token
        When set, every route but ``/v1/health`` needs ``Authorization: Bearer <token>``.
    max_upload_bytes
        Largest accepted request body of ``POST /v1/jobs`` [bytes]; larger ones get 413.
    max_fmu_unpacked_bytes
        Largest total unpacked size of an uploaded FMU [bytes] (zip-bomb guard).
    workers
        Jobs that run at the same time, each in its own process.
    job_timeout_s
        Wall-clock limit of one job [s]; its process group is killed past it.
    job_memory_mb
        Address-space limit of one job process [MiB] (``RLIMIT_AS``).
    dask_scheduler
        Address of a dask.distributed scheduler (``tcp://host:8786``); profile branches of
        every job then run on its workers.
    host, port
        Where ``fmuid serve`` listens; loopback unless told otherwise (``--host``/``--port``
        win over them).
    queue_limit
        Jobs that may wait at once; ``POST /v1/jobs`` answers 429 past it.
    retention_s
        Finished jobs, their results and files are removed this long after they finish [s];
        0 keeps them for good.
    disk_quota_bytes
        Largest size of the data folder [bytes]; new jobs get 507 past it. 0: no quota.
    min_free_bytes
        Free space the data folder's file system needs [bytes]; below it new jobs get 507 and
        health says degraded.
    warm_start
        Fork job processes from a server that imported the engine once (milliseconds per job)
        instead of starting a new interpreter per job (seconds).
    warm_recycle_jobs
        Processes (jobs and report drawings) one warm server forks before it is replaced by a
        new one; the old one stops once they have all ended, and jobs start cold meanwhile. A
        server that crashes is replaced at once; the jobs it took down are queued again.
    max_csv_bytes, max_csv_rows, max_csv_columns, max_cell_chars
        Limits of one uploaded CSV file (see :class:`fmuid.data.InputLimits`).
    max_spec_bytes, max_spec_keys, max_spec_depth
        Limits of the spec: size [bytes], keys of all objects together, nesting depth. The
        size bounds a design job's experiment space too.
    max_model_description_bytes, max_model_variables
        Limits of an uploaded FMU's ``modelDescription.xml``: unpacked size [bytes], variables.
    probe_timeout_s, probe_memory_mb
        Time [s] and address space [MiB] of the process that loads an uploaded binary.
    check_workers
        Submissions checked at the same time, each in its own long-lived process (uploads
        beyond that wait); nothing a submission holds is parsed in the service process.
    check_timeout_s, check_memory_mb
        Wall-clock time [s] and address space [MiB] of the check of one submission; its
        process (and every process it started) is killed past either.
    check_wait_s
        How long a submission waits for a free checking process before it gets 503 [s].
    draw_workers
        Reports drawn at the same time, each in its own process; further first requests of
        reports wait for a turn without holding a thread of the other routes.
    draw_memory_mb
        Address-space limit of one drawing process [MiB].
    max_connections
        Connections ``fmuid serve`` holds at once (uvicorn's ``limit_concurrency``); requests
        beyond get 503. Lowered to fit the open-file limit (:mod:`fmuid.api.connections`).
    header_timeout_s
        A connection whose request head is not complete this long after it opened (or after
        its last response) is closed [s] (slowloris).
    keep_alive_s
        An idle kept-alive connection is closed after this long [s].

    """

    model_config = SettingsConfigDict(env_prefix="FMUID_", extra="ignore")

    data_dir: Path = Field(default_factory=default_data_dir)
    db_path: Path | None = None
    api_token: str | None = None
    max_upload_bytes: int = Field(default=50 * 1024 * 1024, gt=0)
    max_fmu_unpacked_bytes: int = Field(default=200 * 1024 * 1024, gt=0)
    workers: int = Field(default=1, ge=1)
    job_timeout_s: float = Field(default=3600.0, gt=0)
    job_memory_mb: int = Field(default=4096, ge=64)
    dask_scheduler: str | None = None
    host: str = "127.0.0.1"
    port: int = Field(default=8000, ge=0, le=65535)
    queue_limit: int = Field(default=100, ge=1)
    retention_s: float = Field(default=30 * 86400.0, ge=0)
    disk_quota_bytes: int = Field(default=0, ge=0)
    min_free_bytes: int = Field(default=100 * 1024 * 1024, ge=0)
    warm_start: bool = True
    warm_recycle_jobs: int = Field(default=200, ge=1)
    max_csv_bytes: int = Field(default=_INPUT.max_csv_bytes, ge=1)
    max_csv_rows: int = Field(default=_INPUT.max_csv_rows, ge=1)
    max_csv_columns: int = Field(default=_INPUT.max_csv_columns, ge=2)
    max_cell_chars: int = Field(default=_INPUT.max_cell_chars, ge=1)
    max_spec_bytes: int = Field(default=_INPUT.max_spec_bytes, ge=1)
    max_spec_keys: int = Field(default=_INPUT.max_spec_keys, ge=1)
    max_spec_depth: int = Field(default=_INPUT.max_spec_depth, ge=4)
    max_model_description_bytes: int = Field(default=_FMU.max_model_description_bytes, ge=1)
    max_model_variables: int = Field(default=_FMU.max_model_variables, ge=1)
    probe_timeout_s: float = Field(default=_FMU.probe_timeout_s, gt=0)
    probe_memory_mb: int = Field(default=_FMU.probe_memory_mb, ge=64)
    check_workers: int = Field(default=2, ge=1)
    check_timeout_s: float = Field(default=60.0, gt=0)
    check_memory_mb: int = Field(default=2048, ge=256)
    check_wait_s: float = Field(default=120.0, gt=0)
    draw_workers: int = Field(default=2, ge=1)
    draw_memory_mb: int = Field(default=2048, ge=256)
    max_connections: int = Field(default=4096, ge=16)
    header_timeout_s: float = Field(default=10.0, gt=0)
    keep_alive_s: int = Field(default=5, ge=1)

    @model_validator(mode="after")
    def _resolve_paths(self) -> Settings:
        self.data_dir = self.data_dir.expanduser().resolve()
        if self.db_path is None:
            self.db_path = self.data_dir / "jobs.sqlite"
        else:
            self.db_path = self.db_path.expanduser().resolve()
        if not self.api_token:
            self.api_token = None
        if not self.dask_scheduler:
            self.dask_scheduler = None
        return self

    @property
    def database(self) -> Path:
        """The SQLite file of the job store (``db_path`` resolved)."""
        assert self.db_path is not None
        return self.db_path

    @property
    def input_limits(self) -> InputLimits:
        """The limits of uploaded CSV files and specs."""
        return InputLimits(
            max_csv_bytes=self.max_csv_bytes,
            max_csv_rows=self.max_csv_rows,
            max_csv_columns=self.max_csv_columns,
            max_cell_chars=self.max_cell_chars,
            max_spec_bytes=self.max_spec_bytes,
            max_spec_keys=self.max_spec_keys,
            max_spec_depth=self.max_spec_depth,
        )

    @property
    def fmu_limits(self) -> FmuLimits:
        """The limits of the checks of an uploaded FMU."""
        return FmuLimits(
            max_fmu_unpacked_bytes=self.max_fmu_unpacked_bytes,
            max_model_description_bytes=self.max_model_description_bytes,
            max_model_variables=self.max_model_variables,
            probe_timeout_s=self.probe_timeout_s,
            probe_memory_mb=self.probe_memory_mb,
        )
