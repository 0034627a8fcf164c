"""``/v1/jobs``: submit, list, inspect, fetch the result of and cancel jobs."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, File, Form, HTTPException, Query, Response, UploadFile

from fmuid.api.deps import get_job, get_pool, get_settings, get_store, get_supervisor
from fmuid.api.results import ResultOut
from fmuid.api.schemas import ErrorOut, JobCreated, JobList, JobOut, Kind
from fmuid.api.submission import SubmissionError, Upload, submit
from fmuid.api.vetting import PoolBusy, VettingPool
from fmuid.jobs.store import FINAL_STATUSES, Job, JobStore
from fmuid.jobs.worker import Supervisor
from fmuid.settings import Settings

router = APIRouter(prefix="/v1/jobs", tags=["jobs"])

SQLITE_MAX_INT = 2**63 - 1  # larger integers overflow SQLite's OFFSET (found by schemathesis)

_ERRORS: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorOut, "description": "Missing or wrong bearer token."},
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
        503: {
            "model": ErrorOut,
            "description": "The named built-in model is not built, or every checking process"
            " stayed busy for FMUID_CHECK_WAIT_S.",
        },
    },
)
async def create_job(
    kind: Annotated[Kind, Form(description="What to compute.")],
    spec: Annotated[str, Form(description="The study specification (JSON text).")],
    data: Annotated[list[UploadFile], File(description="CSV files, one per experiment.")],
    store: Annotated[JobStore, Depends(get_store)],
    settings: Annotated[Settings, Depends(get_settings)],
    supervisor: Annotated[Supervisor, Depends(get_supervisor)],
    pool: Annotated[VettingPool, Depends(get_pool)],
    fmu: Annotated[
        UploadFile | None, File(description="An FMI 2.0/3.0 FMU (co-simulation or model exchange).")
    ] = None,
    model: Annotated[
        str | None, Form(description="Name of a built-in FMU, instead of 'fmu'.")
    ] = None,
) -> JobCreated:
    """Check the inputs (in a checking process) and queue a job; its id comes back (202)."""
    try:
        job = await pool.run(
            submit,
            store,
            pool,
            settings,
            kind,
            spec,
            [Upload(d.filename, d.file) for d in data],
            Upload(fmu.filename, fmu.file) if fmu is not None else None,
            model or None,
        )
    except SubmissionError as exc:
        raise HTTPException(status_code=exc.status_code, detail=str(exc)) from exc
    except PoolBusy as exc:
        raise HTTPException(status_code=503, detail=str(exc)) from exc
    supervisor.wake()
    return JobCreated(id=job.id)


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


@router.delete(
    "/{job_id}",
    response_model=JobOut,
    responses={**_ERRORS, 409: {"model": ErrorOut, "description": "The job has finished."}},
)
def cancel_job(
    job: Annotated[Job, Depends(get_job)],
    store: Annotated[JobStore, Depends(get_store)],
    supervisor: Annotated[Supervisor, Depends(get_supervisor)],
) -> JobOut:
    """Cancel a queued or running job; its process is killed at once."""
    if job.status in FINAL_STATUSES and job.status != "cancelled":
        raise HTTPException(status_code=409, detail=f"job {job.id} is already {job.status}")
    if store.cancel(job.id):
        supervisor.cancel(job.id)
    current = store.get(job.id)
    assert current is not None
    return JobOut.from_job(current)
