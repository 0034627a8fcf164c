"""Build the FastAPI application of the service and run it with uvicorn."""

from __future__ import annotations

import logging
import signal
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import uvicorn
from fastapi import FastAPI
from fastapi.exceptions import RequestValidationError

from fmuid.api.auth import BearerAuth
from fmuid.api.connections import connection_limit, protocol, raise_open_files
from fmuid.api.drawing import ReportDrawer
from fmuid.api.failures import add_failure_handlers
from fmuid.api.limits import BodyLimit
from fmuid.api.openapi import answer_options, document_errors, serve_docs, validation_error
from fmuid.api.routers import health, jobs, reports
from fmuid.intake.pool import VettingPool
from fmuid.jobs.health import StoreHealth
from fmuid.jobs.store import JobStore
from fmuid.jobs.worker import Supervisor
from fmuid.model.world import open_registry
from fmuid.settings import Settings

logger = logging.getLogger(__name__)

DESCRIPTION = """Profile-likelihood identifiability of FMU models as a service.

Submit a job (`fit`, `profile` or `diagnose`) with CSV data, a JSON spec and an FMU (uploaded or
built-in); poll its status; fetch its result JSON and HTML report. Uploaded FMUs are native code
and run in isolated, time- and memory-limited processes.
"""


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the application: job store, supervisor of job processes, routes.

    Parameters
    ----------
    settings
        The configuration; read from ``FMUID_*`` environment variables when ``None``.

    Returns
    -------
    FastAPI
        The app; its supervisor starts and stops with the app's lifespan.

    """
    settings = settings or Settings()
    store = JobStore(settings.database, settings.data_dir, max_queued=settings.queue_limit)
    supervisor = Supervisor(settings, store)
    vetting = VettingPool(
        settings.check_workers,
        settings.check_memory_mb,
        settings.check_timeout_s,
        settings.check_wait_s,
    )

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        with open_registry():
            supervisor.start()
            logger.info(
                "fmuid service: data in %s, %d worker(s)", settings.data_dir, settings.workers
            )
            yield
            vetting.close()
            supervisor.stop()

    app = FastAPI(
        title="fmuid",
        version="0.1.0",
        description=DESCRIPTION,
        lifespan=lifespan,
        docs_url=None,
        redoc_url=None,
    )
    app.state.settings = settings
    app.state.store = store
    app.state.supervisor = supervisor
    app.state.store_health = StoreHealth(
        settings.database, settings.data_dir, settings.min_free_bytes, settings.disk_quota_bytes
    )
    app.state.vetting = vetting
    app.state.drawer = ReportDrawer(settings, supervisor.warm)
    for router in (health.router, jobs.router, reports.router):
        answer_options(router)
        app.include_router(router)

    app.add_exception_handler(RequestValidationError, validation_error)
    add_failure_handlers(app)
    document_errors(app, secured=settings.api_token is not None)
    serve_docs(app)

    app.add_middleware(BodyLimit, limit=settings.max_upload_bytes)
    if settings.api_token:  # added last, so it runs first: no body is read without the token
        app.add_middleware(BearerAuth, token=settings.api_token)
    return app


def serve(
    host: str | None = None, port: int | None = None, settings: Settings | None = None
) -> None:
    """Run the service with uvicorn until interrupted (``fmuid serve``).

    Parameters
    ----------
    host, port
        Where to listen; default from ``settings`` (``127.0.0.1:8000``). Binding to anything but
        loopback exposes FMU execution to the network: set ``FMUID_API_TOKEN`` then.
    settings
        The configuration; from ``FMUID_*`` environment variables when ``None``.

    """
    settings = settings or Settings()
    # uvicorn raises SIGTERM again after its graceful stop: exit normally then, so that the
    # exit handlers run (multiprocessing removes its pymp-* folder from TMPDIR)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    host = host or settings.host
    port = settings.port if port is None else port
    if settings.api_token is None and host not in ("127.0.0.1", "localhost", "::1"):
        logger.warning(
            "listening on %s without FMUID_API_TOKEN: anyone who reaches it can run code", host
        )
    open_files = raise_open_files()
    config = uvicorn.Config(
        create_app(settings),
        host=host,
        port=port,
        log_level="info",
        http=protocol(settings.header_timeout_s),
        limit_concurrency=connection_limit(settings.max_connections, open_files),
        timeout_keep_alive=settings.keep_alive_s,
    )
    uvicorn.Server(config).run()
