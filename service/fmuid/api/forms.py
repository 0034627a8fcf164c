"""Multipart bodies parsed in a thread, never in the event loop.

Starlette parses a multipart body in the event loop, a Python callback per chunk, while the body
arrives; a large upload (or one crafted to be slow to split into parts) then delays every other
request, health included. :class:`FormOffLoop` routes first spool the body to a temporary file
(the loop only moves bytes; the writes happen in a thread, a megabyte at a time), then parse it in
a thread of their own with Starlette's parser, and hand the parsed form to FastAPI, which
validates the fields as usual. At most :data:`PARSERS` bodies are parsed at once.
"""

from __future__ import annotations

import asyncio
import tempfile
from collections.abc import AsyncGenerator, Callable, Coroutine
from typing import IO, Any

import anyio
import anyio.to_thread
from fastapi import HTTPException, Request, Response
from fastapi.routing import APIRoute
from starlette.datastructures import FormData, Headers
from starlette.formparsers import MultiPartException, MultiPartParser

PARSERS = 2
"""Bodies parsed at the same time; more wait for a free thread."""
SPOOL_MEMORY = 1024 * 1024
"""A body is kept in memory up to this size [bytes], then on disk."""
CHUNK = 1024 * 1024
"""Bytes written to the spool, and fed to the parser, at a time."""

_limiter: anyio.CapacityLimiter | None = None


class FormOffLoop(APIRoute):
    """A route whose multipart body is parsed in a thread (see the module's docstring)."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        """Wrap FastAPI's handler: spool and parse a multipart body before it runs."""
        handle = super().get_route_handler()

        async def parse_then_handle(request: Request) -> Response:
            if request.headers.get("content-type", "").startswith("multipart/form-data"):
                request._form = await parsed_form(request)
            return await handle(request)

        return parse_then_handle


async def parsed_form(request: Request) -> FormData:
    """Spool ``request``'s body, then parse it in a thread; 400 when it is no valid multipart."""
    global _limiter
    if _limiter is None:
        _limiter = anyio.CapacityLimiter(PARSERS)
    spool = tempfile.SpooledTemporaryFile(max_size=SPOOL_MEMORY)  # noqa: SIM115 (closed below)
    try:
        pending: list[bytes] = []
        size = 0
        async for chunk in request.stream():
            pending.append(chunk)
            size += len(chunk)
            if size >= CHUNK:
                await anyio.to_thread.run_sync(spool.write, b"".join(pending))
                pending, size = [], 0
        spool.write(b"".join(pending))
        spool.seek(0)
        try:
            return await anyio.to_thread.run_sync(_parse, request.headers, spool, limiter=_limiter)
        except MultiPartException as exc:
            raise HTTPException(status_code=400, detail=exc.message) from exc
    finally:
        spool.close()


def _parse(headers: Headers, spool: IO[bytes]) -> FormData:
    """Parse the spooled body with Starlette's parser, in this thread's own event loop."""

    async def chunks() -> AsyncGenerator[bytes, None]:
        while chunk := spool.read(CHUNK):
            yield chunk
        yield b""

    return asyncio.run(MultiPartParser(headers, chunks()).parse())
