"""The rows of the job store as values: :class:`Job` and its :class:`Dataset` files.

The job kinds are :data:`Kind` and the states :data:`Status`, written here once.
"""

from __future__ import annotations

import json
import sqlite3
from dataclasses import dataclass
from typing import Literal, get_args

Kind = Literal["fit", "profile", "diagnose", "design"]
"""What a job computes."""
KINDS: tuple[Kind, ...] = get_args(Kind)
Status = Literal["queued", "running", "done", "failed", "cancelled"]
"""Where a job is: waiting, running, or one of the final states."""
STATUSES: tuple[Status, ...] = get_args(Status)
FINAL_STATUSES: tuple[Status, ...] = ("done", "failed", "cancelled")


TEST_DATA = "test_data"
"""Folder of the held-out CSV files of a job, and the prefix of their dataset names
(``test_data/<name>``)."""


@dataclass(frozen=True)
class Dataset:
    """One uploaded CSV file: its original file name (the experiment name) and content hash."""

    name: str
    sha256: str


@dataclass(frozen=True)
class Job:
    """One row of the jobs table.

    Attributes
    ----------
    id
        A UUID4 string.
    kind
        One of :data:`KINDS`.
    status
        One of :data:`STATUSES`.
    created, started, finished
        Unix times [s]; ``started``/``finished`` are ``None`` until they happen.
    progress_done, progress_total, progress_stage, progress_detail
        The last progress event the job process reported (the detail: what it is doing).
    error
        Why the job failed or was cancelled.
    fmu_sha256, model_name
        The FMU (a blob) and its model name.
    spec
        The study specification as JSON text, exactly as submitted.
    datasets
        The CSV files, in submission order (a design stored before the ``space`` column: its
        space as the one dataset).
    attempts
        How many times a job process was started for it.
    pid
        Process id of its job process while running.
    space
        A design's experiment space as JSON text, exactly as submitted (``None``: other kinds,
        and designs stored before this column).

    """

    id: str
    kind: Kind
    status: Status
    created: float
    started: float | None
    finished: float | None
    progress_done: int
    progress_total: int
    progress_stage: str
    progress_detail: str
    error: str | None
    fmu_sha256: str
    model_name: str
    spec: str
    datasets: tuple[Dataset, ...]
    attempts: int
    pid: int | None
    space: str | None = None

    @classmethod
    def from_row(cls, row: sqlite3.Row) -> Job:
        """Build a job from a ``SELECT * FROM jobs`` row."""
        values = dict(row)
        values["datasets"] = tuple(Dataset(**d) for d in json.loads(values["datasets"]))
        return cls(**values)
