"""``GET /v1/health``: liveness, queue depth and the state of the job store (no token needed)."""

from __future__ import annotations

import sqlite3
from typing import Annotated

from fastapi import APIRouter, Depends

from fmuid.api.deps import get_settings, get_store, get_store_health, get_supervisor
from fmuid.api.schemas import Health
from fmuid.jobs.health import StoreHealth
from fmuid.jobs.store import JobStore
from fmuid.jobs.worker import Supervisor
from fmuid.settings import Settings

router = APIRouter(prefix="/v1", tags=["health"])


@router.get("/health", response_model=Health)
def health(
    store: Annotated[JobStore, Depends(get_store)],
    settings: Annotated[Settings, Depends(get_settings)],
    checks: Annotated[StoreHealth, Depends(get_store_health)],
    supervisor: Annotated[Supervisor, Depends(get_supervisor)],
) -> Health:
    """Say the service is alive, how many jobs wait and run, and whether the store is sound."""
    problems = checks.problems()
    if supervisor.problem:
        problems.append(supervisor.problem)
    try:
        counts: dict[str, int | None] = dict(store.counts())
    except sqlite3.Error as exc:
        problems.append(f"cannot read the job store: {exc}")
        counts = {"queued": None, "running": None}
    return Health(
        status="degraded" if problems else "ok",
        problems=problems,
        queued=counts["queued"],
        running=counts["running"],
        workers=settings.workers,
        dask_scheduler=settings.dask_scheduler,
    )
