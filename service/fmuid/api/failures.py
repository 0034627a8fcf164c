"""Answers for failures no route expects: always JSON :class:`~fmuid.api.schemas.ErrorOut`.

A job store that cannot be read or written (a full disk, a damaged file) answers 503 naming the
problem; anything else unexpected answers 500 with the exception's type, never a plain-text page.
"""

from __future__ import annotations

import logging
import sqlite3

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse

from fmuid.jobs.store import StoreError

logger = logging.getLogger(__name__)


async def store_failure(request: Request, exc: Exception) -> JSONResponse:
    """Answer 503 when the job store fails."""
    logger.error("job store failure on %s %s: %s", request.method, request.url.path, exc)
    return JSONResponse({"detail": f"the job store is unavailable: {exc}"}, status_code=503)


async def internal_failure(request: Request, exc: Exception) -> JSONResponse:
    """Answer 500 with a JSON body for any other unexpected exception."""
    logger.exception("internal error on %s %s", request.method, request.url.path, exc_info=exc)
    return JSONResponse({"detail": f"internal error: {type(exc).__name__}"}, status_code=500)


def add_failure_handlers(app: FastAPI) -> None:
    """Register the handlers on ``app``."""
    app.add_exception_handler(StoreError, store_failure)
    app.add_exception_handler(sqlite3.Error, store_failure)
    app.add_exception_handler(OSError, store_failure)
    app.add_exception_handler(Exception, internal_failure)
