"""Objects the routes share, kept on ``app.state`` by :func:`fmuid.api.create_app`."""

from __future__ import annotations

from fastapi import HTTPException, Request

from fmuid.api.drawing import ReportDrawer
from fmuid.intake.pool import VettingPool
from fmuid.jobs.health import StoreHealth
from fmuid.jobs.store import Job, JobStore
from fmuid.jobs.worker import Supervisor
from fmuid.settings import Settings


def get_settings(request: Request) -> Settings:
    """Return the settings the app was built with."""
    settings: Settings = request.app.state.settings
    return settings


def get_store(request: Request) -> JobStore:
    """Return the job store."""
    store: JobStore = request.app.state.store
    return store


def get_pool(request: Request) -> VettingPool:
    """Return the processes that check submissions."""
    pool: VettingPool = request.app.state.vetting
    return pool


def get_supervisor(request: Request) -> Supervisor:
    """Return the supervisor running the jobs."""
    supervisor: Supervisor = request.app.state.supervisor
    return supervisor


def get_drawer(request: Request) -> ReportDrawer:
    """Return what draws reports on their first request."""
    drawer: ReportDrawer = request.app.state.drawer
    return drawer


def get_store_health(request: Request) -> StoreHealth:
    """Return the checks of the job store."""
    checks: StoreHealth = request.app.state.store_health
    return checks


def get_job(job_id: str, request: Request) -> Job:
    """Return the job named in the path, or answer 404."""
    job = get_store(request).get(job_id)
    if job is None:
        raise HTTPException(status_code=404, detail=f"no job with id {job_id!r}")
    return job
