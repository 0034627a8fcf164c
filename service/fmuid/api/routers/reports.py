"""``/v1/jobs/{id}/report``: the HTML report of a done job and the image files beside it.

The report (``<data_dir>/reports/<id>/index.html`` and PNGs) is drawn on the first request for it
or one of its files (:mod:`fmuid.api.drawing`: once, in a process), then served. The
page gets ``<base href="report/">`` so that its relative links resolve under
``/v1/jobs/{id}/report/``. With ``FMUID_API_TOKEN`` set, a browser opens the page through its
signed link (``GET /v1/jobs/{id}/report-link``, asked with the token), and each link of the page
to a file beside it carries that file's signature (:func:`fmuid.api.auth.sign`); the page's
figures are embedded, so a saved page keeps them.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException
from fastapi.responses import FileResponse, HTMLResponse
from pydantic import BaseModel, Field

from fmuid.api.auth import sign
from fmuid.api.deps import get_drawer, get_job, get_settings
from fmuid.api.drawing import DrawingFailed, ReportDrawer
from fmuid.api.schemas import UNAUTHORIZED, ErrorOut
from fmuid.jobs.store import Job
from fmuid.settings import Settings

REPORT_HEADERS = {
    "Content-Security-Policy": "default-src 'none'; img-src 'self' data:; style-src 'self'"
    " 'unsafe-inline'; base-uri 'self'; form-action 'none'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
}
"""Headers of report pages and files: the page runs no script and loads nothing from elsewhere,
whatever an uploaded model's names put into it."""

router = APIRouter(prefix="/v1/jobs", tags=["reports"])


class ReportLink(BaseModel):
    """Answer of ``GET /v1/jobs/{id}/report-link``."""

    url: str = Field(
        description="Path of the report page that a browser opens without the bearer token "
        "(with FMUID_API_TOKEN set it carries the page's signature, ?sig=); join it to the "
        "service's address."
    )


_FILE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")
_LINK = re.compile(r'\b(src|href)="([A-Za-z0-9_][A-Za-z0-9_.-]*)"')
"""A link to a file beside the page (which gets a signature when a token is set)."""
MAX_FILE_NAME = 255
"""Longest file name the file system takes; a longer one is simply not in the report."""
_RESPONSES: dict[int | str, dict[str, Any]] = {
    401: UNAUTHORIZED,
    404: {"model": ErrorOut, "description": "No such job or file."},
    409: {"model": ErrorOut, "description": "The job is not done."},
    503: {"model": ErrorOut, "description": "The report could not be drawn (the cause)."},
}


async def _report_dir(job: Job, drawer: ReportDrawer) -> Path:
    if job.status != "done":
        raise HTTPException(status_code=409, detail=f"job {job.id} is {job.status}; no report")
    try:
        return await drawer.report_dir(job.id)
    except DrawingFailed as exc:
        raise HTTPException(
            status_code=503, detail=f"the report of job {job.id} could not be drawn: {exc}"
        ) from exc


@router.get(
    "/{job_id}/report",
    response_class=HTMLResponse,
    responses={**_RESPONSES, 200: {"content": {"text/html": {}}, "description": "The report."}},
)
async def get_report(
    job: Annotated[Job, Depends(get_job)],
    settings: Annotated[Settings, Depends(get_settings)],
    drawer: Annotated[ReportDrawer, Depends(get_drawer)],
) -> HTMLResponse:
    """Give the HTML report of a done job: plots and tables (drawn on the first request)."""
    html = (await _report_dir(job, drawer) / "index.html").read_text(encoding="utf-8")
    base = '<base href="report/">'
    head = re.search(r"<head[^>]*>", html, flags=re.IGNORECASE)
    html = html[: head.end()] + base + html[head.end() :] if head else base + html
    if settings.api_token:
        prefix = f"/v1/jobs/{job.id}/report/"
        html = _LINK.sub(
            lambda m: f'{m[1]}="{m[2]}?sig={sign(settings.api_token or "", prefix + m[2])}"', html
        )
    return HTMLResponse(html, headers=REPORT_HEADERS)


@router.get(
    "/{job_id}/report-link",
    response_model=ReportLink,
    responses={401: UNAUTHORIZED, 404: _RESPONSES[404]},
)
async def get_report_link(
    job: Annotated[Job, Depends(get_job)],
    settings: Annotated[Settings, Depends(get_settings)],
) -> ReportLink:
    """Give the link that opens a job's report page in a browser, which cannot send the token.

    The signature opens this job's page and nothing else; it stays valid while the token does.
    """
    path = f"/v1/jobs/{job.id}/report"
    return ReportLink(
        url=f"{path}?sig={sign(settings.api_token, path)}" if settings.api_token else path
    )


@router.get(
    "/{job_id}/report/{file_name}",
    response_class=FileResponse,
    responses={
        **_RESPONSES,
        200: {"content": {"image/png": {}}, "description": "A figure of the report."},
    },
)
async def get_report_file(
    file_name: str,
    job: Annotated[Job, Depends(get_job)],
    drawer: Annotated[ReportDrawer, Depends(get_drawer)],
) -> FileResponse:
    """Give one file of a job's report (an image the page links)."""
    directory = await _report_dir(job, drawer)
    path = directory / file_name
    if len(file_name) > MAX_FILE_NAME or not _FILE_NAME.fullmatch(file_name) or not path.is_file():
        raise HTTPException(status_code=404, detail=f"no file {file_name[:80]!r} in the report")
    return FileResponse(path, headers=REPORT_HEADERS)
