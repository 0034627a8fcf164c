"""``/v1/jobs/{id}/report``: the HTML report of a done job and the image files beside it.

The job process writes the report (``<data_dir>/reports/<id>/index.html`` and PNGs) right after
storing the result; here it is only served (after waiting while it is still being drawn). The
page gets ``<base href="report/">`` so that its relative image links resolve under
``/v1/jobs/{id}/report/``; with ``FMUID_API_TOKEN`` set, each such link carries a signature that
opens that file in a browser (:func:`fmuid.api.auth.sign`).
"""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException
from fastapi.responses import FileResponse, HTMLResponse

from fmuid.api.auth import sign
from fmuid.api.deps import get_job, get_settings
from fmuid.api.schemas import ErrorOut
from fmuid.jobs.store import Job
from fmuid.settings import Settings

router = APIRouter(prefix="/v1/jobs", tags=["reports"])

REPORT_WAIT_S = 60.0
"""The result is stored before the report is drawn: a report asked for meanwhile waits this long."""
_FILE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")
_LINK = re.compile(r'\b(src|href)="([A-Za-z0-9_][A-Za-z0-9_.-]*)"')
"""A link to a file beside the page (which gets a signature when a token is set)."""
MAX_FILE_NAME = 255
"""Longest file name the file system takes; a longer one is simply not in the report."""
_RESPONSES: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorOut, "description": "Missing or wrong bearer token."},
    404: {"model": ErrorOut, "description": "No such job or file."},
    409: {"model": ErrorOut, "description": "The job is not done."},
    503: {"model": ErrorOut, "description": "No report could be written for this job."},
}


def _report_dir(job: Job, settings: Settings) -> Path:
    if job.status != "done":
        raise HTTPException(status_code=409, detail=f"job {job.id} is {job.status}; no report")
    directory = settings.data_dir / "reports" / job.id
    _wait_while_drawn(directory)
    error = directory.with_name(job.id + ".error")
    if error.is_file():
        raise HTTPException(
            status_code=503, detail=f"the report of job {job.id} failed: {error.read_text()}"
        )
    if not (directory / "index.html").is_file():
        raise HTTPException(
            status_code=503, detail=f"no report was written for job {job.id} (fmuid.report missing)"
        )
    return directory


def _wait_while_drawn(directory: Path) -> None:
    """Wait (at most :data:`REPORT_WAIT_S`) while the job process draws the report of a done job."""
    drawing = directory.with_name(directory.name + ".tmp")
    deadline = time.monotonic() + REPORT_WAIT_S
    while drawing.is_dir() and not directory.is_dir() and time.monotonic() < deadline:
        time.sleep(0.1)


@router.get(
    "/{job_id}/report",
    response_class=HTMLResponse,
    responses={**_RESPONSES, 200: {"content": {"text/html": {}}, "description": "The report."}},
)
def get_report(
    job: Annotated[Job, Depends(get_job)], settings: Annotated[Settings, Depends(get_settings)]
) -> HTMLResponse:
    """Give the HTML report of a done job: plots and tables."""
    html = (_report_dir(job, settings) / "index.html").read_text(encoding="utf-8")
    base = '<base href="report/">'
    head = re.search(r"<head[^>]*>", html, flags=re.IGNORECASE)
    html = html[: head.end()] + base + html[head.end() :] if head else base + html
    if settings.api_token:
        prefix = f"/v1/jobs/{job.id}/report/"
        html = _LINK.sub(
            lambda m: f'{m[1]}="{m[2]}?sig={sign(settings.api_token or "", prefix + m[2])}"', html
        )
    return HTMLResponse(html)


@router.get(
    "/{job_id}/report/{file_name}",
    response_class=FileResponse,
    responses={
        **_RESPONSES,
        200: {"content": {"image/png": {}}, "description": "A figure of the report."},
    },
)
def get_report_file(
    file_name: str,
    job: Annotated[Job, Depends(get_job)],
    settings: Annotated[Settings, Depends(get_settings)],
) -> FileResponse:
    """Give one file of a job's report (an image the page links)."""
    directory = _report_dir(job, settings)
    path = directory / file_name
    if len(file_name) > MAX_FILE_NAME or not _FILE_NAME.fullmatch(file_name) or not path.is_file():
        raise HTTPException(status_code=404, detail=f"no file {file_name[:80]!r} in the report")
    return FileResponse(path)
