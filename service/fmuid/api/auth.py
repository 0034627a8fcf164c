"""Bearer-token check of every ``/v1`` route but ``/v1/health``.

It is ASGI middleware rather than a route dependency so that a request without the token is
refused before its body (possibly a large upload) is read.
"""

from __future__ import annotations

import secrets

from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Receive, Scope, Send

OPEN_PATHS = ("/v1/health",)


class BearerAuth:
    """Answer 401 to ``/v1`` requests whose ``Authorization`` is not ``Bearer <token>``.

    Parameters
    ----------
    app
        The application to protect.
    token
        The expected token.

    """

    def __init__(self, app: ASGIApp, token: str):
        self.app = app
        self.token = token.encode()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Pass authorised requests on; answer the others with 401."""
        path: str = scope.get("path", "")
        if scope["type"] != "http" or not path.startswith("/v1/") or path in OPEN_PATHS:
            await self.app(scope, receive, send)
            return
        header = dict(scope["headers"]).get(b"authorization", b"")
        scheme, _, given = header.partition(b" ")
        if scheme.lower() == b"bearer" and secrets.compare_digest(given.strip(), self.token):
            await self.app(scope, receive, send)
            return
        detail = "missing bearer token" if not header else "wrong bearer token"
        response = JSONResponse(
            {"detail": f"{detail}: send 'Authorization: Bearer <FMUID_API_TOKEN>'"},
            status_code=401,
            headers={"WWW-Authenticate": 'Bearer realm="fmuid"'},
        )
        await response(scope, receive, send)
