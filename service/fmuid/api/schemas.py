"""Request and response bodies of the HTTP API (separate from the engine's result objects)."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any, Literal

from pydantic import BaseModel, Field

from fmuid.jobs.records import Job, Kind, Status


class JobCreated(BaseModel):
    """Answer of ``POST /v1/jobs``."""

    id: str = Field(description="Job id (UUID).")
    status: Literal["queued"] = "queued"


class JobProgress(BaseModel):
    """How far a job has come: profile points (or generations, candidates) done of total."""

    done: int
    total: int
    stage: str = Field(default="", description="Engine stage reporting, e.g. 'profile'.")
    detail: str = Field(
        default="",
        description="What the job is doing, for people, e.g. 'C_atf +: 7 points' or 'refine: "
        "120 evaluations, start 1/1, chi2 51.3, 130 simulations'.",
    )


class DatasetOut(BaseModel):
    """One CSV file of a job."""

    name: str
    sha256: str


class JobOut(BaseModel):
    """State of one job (``GET /v1/jobs/{id}``)."""

    id: str
    kind: Kind
    status: Status
    progress: JobProgress
    error: str | None = Field(description="Why the job failed or was cancelled.")
    created: datetime
    started: datetime | None
    finished: datetime | None
    model_name: str
    fmu_sha256: str
    datasets: list[DatasetOut]
    attempts: int = Field(description="Job processes started for it (restarts add one).")

    @classmethod
    def from_job(cls, job: Job) -> JobOut:
        """Build the response from a stored job."""
        return cls(
            id=job.id,
            kind=job.kind,
            status=job.status,
            progress=JobProgress(
                done=job.progress_done,
                total=job.progress_total,
                stage=job.progress_stage,
                detail=job.progress_detail,
            ),
            error=job.error,
            created=_time(job.created),
            started=_time(job.started) if job.started is not None else None,
            finished=_time(job.finished) if job.finished is not None else None,
            model_name=job.model_name,
            fmu_sha256=job.fmu_sha256,
            datasets=[DatasetOut(name=d.name, sha256=d.sha256) for d in job.datasets],
            attempts=job.attempts,
        )


class JobList(BaseModel):
    """Answer of ``GET /v1/jobs``: jobs, newest first."""

    jobs: list[JobOut]


class Health(BaseModel):
    """Answer of ``GET /v1/health``."""

    status: Literal["ok", "degraded"] = Field(
        default="ok", description="'degraded' when the job store or its disk has a problem."
    )
    problems: list[str] = Field(default=[], description="What is wrong when degraded.")
    queued: int | None = Field(description="Jobs waiting for a worker (None: store unreadable).")
    running: int | None = Field(description="Jobs running now (None: store unreadable).")
    workers: int = Field(description="Jobs that may run at the same time.")
    dask_scheduler: str | None = Field(description="Scheduler that profile branches run on.")


class ErrorOut(BaseModel):
    """Body of every 4xx/5xx answer the service gives on purpose."""

    detail: str


UNAUTHORIZED: dict[str, Any] = {"model": ErrorOut, "description": "Missing or wrong bearer token."}
"""The 401 answer of every route but health, as documented in the OpenAPI schema."""


def _time(seconds: float) -> datetime:
    return datetime.fromtimestamp(seconds, tz=UTC)
