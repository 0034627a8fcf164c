"""``GET /v1/health``: liveness and queue depth (no token needed)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends

from fmuid.api.deps import get_settings, get_store
from fmuid.api.schemas import Health
from fmuid.jobs.store import JobStore
from fmuid.settings import Settings

router = APIRouter(prefix="/v1", tags=["health"])


@router.get("/health", response_model=Health)
def health(
    store: Annotated[JobStore, Depends(get_store)],
    settings: Annotated[Settings, Depends(get_settings)],
) -> Health:
    """Say the service is alive and how many jobs wait and run."""
    counts = store.counts()
    return Health(
        queued=counts["queued"],
        running=counts["running"],
        workers=settings.workers,
        dask_scheduler=settings.dask_scheduler,
    )
