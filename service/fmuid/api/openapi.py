"""The published OpenAPI schema: every error answer as it really is, and the bearer scheme.

FastAPI documents error answers of a route under the route's own media type (``text/html`` for
the report page) and the 422 of request validation as its list-shaped ``HTTPValidationError``.
The service answers every error with ``application/json`` :class:`ErrorOut` (see
:func:`validation_error`), so the schema is rewritten to say so; schemathesis checks that the
two agree (``tests/hardening/test_openapi_fuzz.py``).
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from fmuid.api.auth import OPEN_PATHS
from fmuid.api.schemas import ErrorOut

_ERROR_REF = {"$ref": "#/components/schemas/ErrorOut"}
_FRAMEWORK_SCHEMAS = ("HTTPValidationError", "ValidationError")


async def validation_error(request: Request, exc: Exception) -> JSONResponse:
    """Answer a request that does not match the route's parameters with 422 naming each field."""
    assert isinstance(exc, RequestValidationError)
    problems = []
    for error in exc.errors():
        where = ".".join(str(part) for part in error["loc"][1:]) or str(error["loc"][0])
        problems.append(f"{where}: {error['msg'].lower()}")
    return JSONResponse({"detail": "; ".join(problems)}, status_code=422)


def document_errors(app: FastAPI, secured: bool) -> None:
    """Make ``app.openapi()`` declare JSON :class:`ErrorOut` bodies for every 4xx/5xx.

    Parameters
    ----------
    app
        The application whose schema is rewritten (once, on first use).
    secured
        Whether ``FMUID_API_TOKEN`` is set: then every route but the open ones declares the
        bearer scheme.

    """
    build = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            schema = build()
            components = schema.setdefault("components", {})
            schemas = components.setdefault("schemas", {})
            schemas["ErrorOut"] = ErrorOut.model_json_schema()
            for name in _FRAMEWORK_SCHEMAS:
                schemas.pop(name, None)
            if secured:
                components["securitySchemes"] = {"bearer": {"type": "http", "scheme": "bearer"}}
            for path, operations in schema["paths"].items():
                for operation in operations.values():
                    for status, response in operation["responses"].items():
                        if status[0] in "45":
                            response["content"] = {"application/json": {"schema": _ERROR_REF}}
                    if secured and path not in OPEN_PATHS:
                        operation["security"] = [{"bearer": []}]
            app.openapi_schema = schema
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
