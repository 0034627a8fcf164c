"""Bearer-token check of every ``/v1`` route but ``/v1/health``.

It is ASGI middleware rather than a route dependency so that a request without the token is
refused before its body (possibly a large upload) is read. A browser cannot send the token, so
a report page and the files beside it also open with a signature instead (:func:`sign`,
``?sig=``): an HMAC of the path under the token, which opens that one page or file and nothing
else. ``GET /v1/jobs/{id}/report-link`` (with the token) gives the page's signed link.
"""

from __future__ import annotations

import hashlib
import hmac
import re
import secrets
from urllib.parse import parse_qs

from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Receive, Scope, Send

OPEN_PATHS = ("/v1/health",)
_SIGNABLE = re.compile(r"/v1/jobs/[^/]+/report(?:/[^/]+)?")
"""A report page or a file beside it: what a signature may open."""


def sign(token: str, path: str) -> str:
    """Return the signature that opens ``path`` (a report page or file) without the token."""
    return hmac.new(token.encode(), path.encode(), hashlib.sha256).hexdigest()[:32]


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
        if self._bearer(header) or self._signed(scope, path):
            await self.app(scope, receive, send)
            return
        detail = "missing bearer token" if not header else "wrong bearer token"
        response = JSONResponse(
            {"detail": f"{detail}: send 'Authorization: Bearer <FMUID_API_TOKEN>'"},
            status_code=401,
            headers={"WWW-Authenticate": 'Bearer realm="fmuid"'},
        )
        await response(scope, receive, send)

    def _bearer(self, header: bytes) -> bool:
        """Whether an ``Authorization`` header is ``Bearer <token>``."""
        scheme, _, given = header.partition(b" ")
        return scheme.lower() == b"bearer" and secrets.compare_digest(given.strip(), self.token)

    def _signed(self, scope: Scope, path: str) -> bool:
        """Whether a GET of a report page or file carries the right ``sig``."""
        if scope.get("method") != "GET" or not _SIGNABLE.fullmatch(path):
            return False
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        given = query.get("sig", [""])[0]
        return secrets.compare_digest(given, sign(self.token.decode(), path))
