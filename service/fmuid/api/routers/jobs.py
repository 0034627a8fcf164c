"""``/v1/jobs``: submit, list, inspect, fetch the result of, cancel and remove jobs."""

from __future__ import annotations

from typing import Annotated, Any

import anyio.to_thread
from fastapi import APIRouter, Depends, File, Form, HTTPException, Query, Response, UploadFile

from fmuid.api.deps import (
    get_job,
    get_pool,
    get_settings,
    get_store,
    get_store_health,
    get_supervisor,
)
from fmuid.api.forms import FormOffLoop
from fmuid.api.results import ResultOut
from fmuid.api.schemas import UNAUTHORIZED, ErrorOut, JobCreated, JobList, JobOut, Kind
from fmuid.intake.pool import PoolBusy, VettingPool
from fmuid.intake.submission import SubmissionError, Upload, submit
from fmuid.jobs.health import StoreHealth
from fmuid.jobs.housekeeping import delete_jobs
from fmuid.jobs.store import FINAL_STATUSES, Job, JobStore, QueueFull
from fmuid.jobs.worker import Supervisor
from fmuid.settings import Settings

router = APIRouter(prefix="/v1/jobs", tags=["jobs"], route_class=FormOffLoop)

SQLITE_MAX_INT = 2**63 - 1  # larger integers overflow SQLite's OFFSET (found by schemathesis)

_ERRORS: dict[int | str, dict[str, Any]] = {
    401: UNAUTHORIZED,
    404: {"model": ErrorOut, "description": "No job with this id."},
}


@router.post(
    "",
    status_code=202,
    response_model=JobCreated,
    responses={
        400: {"model": ErrorOut, "description": "The multipart body cannot be parsed."},
        401: _ERRORS[401],
        413: {"model": ErrorOut, "description": "The request body exceeds the upload limit."},
        422: {
            "description": "Bad FMU, CSV or spec, or they do not fit together, or one is over a"
            " limit (the reason names it and its FMUID_* setting)."
        },
        429: {"model": ErrorOut, "description": "The queue is full (FMUID_QUEUE_LIMIT)."},
        503: {
            "model": ErrorOut,
            "description": "The job store is damaged or unwritable (health says why), the named"
            " built-in model is not built, or every checking process stayed busy for"
            " FMUID_CHECK_WAIT_S.",
        },
        507: {"model": ErrorOut, "description": "The disk is full or the data over its quota."},
    },
)
async def create_job(
    kind: Annotated[Kind, Form(description="What to compute.")],
    spec: Annotated[str, Form(description="The study specification (JSON text).")],
    data: Annotated[
        list[UploadFile] | None, File(description="CSV files, one per experiment.")
    ] = None,
    *,
    store: Annotated[JobStore, Depends(get_store)],
    settings: Annotated[Settings, Depends(get_settings)],
    supervisor: Annotated[Supervisor, Depends(get_supervisor)],
    checks: Annotated[StoreHealth, Depends(get_store_health)],
    pool: Annotated[VettingPool, Depends(get_pool)],
    space: Annotated[
        UploadFile | None, File(description="Experiment space JSON (kind 'design' only).")
    ] = None,
    fmu: Annotated[
        UploadFile | None, File(description="An FMI 2.0/3.0 FMU (co-simulation or model exchange).")
    ] = None,
    model: Annotated[
        str | None, Form(description="Name of a built-in FMU, instead of 'fmu'.")
    ] = None,
    test_data: Annotated[
        list[UploadFile] | None,
        File(description="Held-out CSV files: the fitted model's simulation error on each."),
    ] = None,
) -> JobCreated:
    """Check the inputs (in a checking process) and queue a job; its id comes back (202)."""
    await anyio.to_thread.run_sync(_check_room, checks, store, settings.queue_limit)
    try:
        job = await pool.run(
            submit,
            store,
            pool,
            settings,
            kind,
            spec,
            [Upload(d.filename, d.file) for d in data or []],
            Upload(fmu.filename, fmu.file) if fmu is not None else None,
            model or None,
            Upload(space.filename, space.file) if space is not None else None,
            [Upload(d.filename, d.file) for d in test_data or []],
        )
    except SubmissionError as exc:
        raise HTTPException(status_code=exc.status_code, detail=str(exc)) from exc
    except QueueFull as exc:
        raise HTTPException(status_code=429, detail=str(exc)) from exc
    except PoolBusy as exc:
        raise HTTPException(status_code=503, detail=str(exc)) from exc
    supervisor.wake()
    return JobCreated(id=job.id)


def _check_room(checks: StoreHealth, store: JobStore, queue_limit: int) -> None:
    """Answer 507 without room, 503 when the store cannot take a job, 429 with a full queue.

    A full disk also makes the store unwritable: its room is checked first, so that the answer
    names the cause (FMUID_MIN_FREE_BYTES) rather than its effect.
    """
    no_room = checks.room_problems()
    if no_room:
        raise HTTPException(status_code=507, detail="; ".join(no_room))
    damaged = checks.database_problems()
    if damaged:
        raise HTTPException(status_code=503, detail="; ".join(damaged))
    queued = store.counts()["queued"]
    if queued >= queue_limit:
        raise HTTPException(
            status_code=429, detail=f"the queue is full: {queued} jobs wait (FMUID_QUEUE_LIMIT)"
        )


@router.get("", response_model=JobList, responses={401: _ERRORS[401]})
def list_jobs(
    store: Annotated[JobStore, Depends(get_store)],
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
    offset: Annotated[int, Query(ge=0, le=SQLITE_MAX_INT)] = 0,
) -> JobList:
    """List jobs, newest first."""
    return JobList(jobs=[JobOut.from_job(j) for j in store.list_jobs(limit, offset)])


@router.get("/{job_id}", response_model=JobOut, responses=_ERRORS)
def get_job_status(job: Annotated[Job, Depends(get_job)]) -> JobOut:
    """Give a job's status, progress and error."""
    return JobOut.from_job(job)


@router.get(
    "/{job_id}/result",
    responses={
        **_ERRORS,
        200: {"model": ResultOut, "description": "The result JSON of the job's kind."},
        409: {"model": ErrorOut, "description": "The job is not done."},
    },
)
def get_result(
    job: Annotated[Job, Depends(get_job)], store: Annotated[JobStore, Depends(get_store)]
) -> Response:
    """Give the result of a done job (409 while it is not done)."""
    text = store.result(job.id) if job.status == "done" else None
    if text is None:
        reason = f": {job.error}" if job.error else ""
        raise HTTPException(status_code=409, detail=f"job {job.id} is {job.status}{reason}")
    return Response(content=text, media_type="application/json")


@router.delete("/{job_id}", response_model=JobOut, responses=_ERRORS)
def cancel_or_remove_job(
    job: Annotated[Job, Depends(get_job)],
    store: Annotated[JobStore, Depends(get_store)],
    supervisor: Annotated[Supervisor, Depends(get_supervisor)],
) -> JobOut:
    """Cancel a queued or running job (its process is killed at once); remove a finished one.

    A finished job (done, failed or cancelled) is removed with its result, report, log and the
    uploads no other job uses; the answer is its last state, and it is 404 afterwards.
    """
    if job.status in FINAL_STATUSES:
        delete_jobs(store, [job.id])
        return JobOut.from_job(job)
    if store.cancel(job.id):
        supervisor.cancel(job.id)
    current = store.get(job.id)
    assert current is not None
    return JobOut.from_job(current)
