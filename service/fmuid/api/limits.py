"""Refuse request bodies over the upload limit with 413, before and while they are read.

A declared ``Content-Length`` over the limit is refused before the application sees the request;
a body without one (chunked) is counted while it is read and refused once it passes the limit.
"""

from __future__ import annotations

from fastapi import HTTPException
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send


def too_large_message(limit: int) -> str:
    """Return the reason given with every 413."""
    return f"the request body exceeds the upload limit of {limit} bytes (FMUID_MAX_UPLOAD_BYTES)"


class BodyLimit:
    """ASGI middleware limiting the request body to ``limit`` bytes.

    Parameters
    ----------
    app
        The application to protect.
    limit
        Largest accepted body [bytes].

    """

    def __init__(self, app: ASGIApp, limit: int):
        self.app = app
        self.limit = limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Refuse or count the body of an HTTP request, then pass it on."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = dict(scope["headers"]).get(b"content-length")
        if declared is not None and (not declared.isdigit() or int(declared) > self.limit):
            response = JSONResponse({"detail": too_large_message(self.limit)}, status_code=413)
            await response(scope, receive, send)
            return
        seen = 0

        async def counted() -> Message:
            nonlocal seen
            message = await receive()
            seen += len(message.get("body", b""))
            if seen > self.limit:
                raise HTTPException(status_code=413, detail=too_large_message(self.limit))
            return message

        await self.app(scope, counted, send)
