"""The published OpenAPI schema: every error answer as it really is, and the bearer scheme.

FastAPI documents error answers of a route under the route's own media type (``text/html`` for
the report page) and the 422 of request validation as its list-shaped ``HTTPValidationError``.
The service answers every error with ``application/json`` :class:`ErrorOut` (see
:func:`validation_error`), so the schema is rewritten to say so; schemathesis checks that the
two agree (``tests/hardening/test_openapi_fuzz.py``). The Swagger UI page at ``/docs`` loads its
script and style from the service itself (the files the ``fastapi-offline`` package ships), so
that it works without internet access.
"""

from __future__ import annotations

import re
from collections.abc import Awaitable, Callable
from importlib.resources import files
from typing import Any

from fastapi import APIRouter, FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.routing import APIRoute
from fastapi.staticfiles import StaticFiles
from starlette.responses import Response

from fmuid.api.auth import OPEN_PATHS
from fmuid.api.schemas import UNAUTHORIZED, ErrorOut
from fmuid.data import Spec

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
            _type_spec_field(schema)
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


DOCS_ASSETS = "/docs-assets"


def serve_docs(app: FastAPI) -> None:
    """Serve Swagger UI at ``/docs`` from files bundled with the service (no CDN).

    The app must be built with ``docs_url=None`` (FastAPI's own page loads from a CDN).
    """
    assets = files("fastapi_offline") / "static"
    app.mount(DOCS_ASSETS, StaticFiles(directory=str(assets)), name="docs-assets")

    @app.get("/docs", include_in_schema=False)
    async def docs() -> HTMLResponse:
        return get_swagger_ui_html(
            openapi_url=app.openapi_url or "/openapi.json",
            title=f"{app.title} - Swagger UI",
            swagger_js_url=f"{DOCS_ASSETS}/swagger-ui-bundle.js",
            swagger_css_url=f"{DOCS_ASSETS}/swagger-ui.css",
            swagger_favicon_url=f"{DOCS_ASSETS}/favicon.png",
        )


def _type_spec_field(schema: dict[str, Any]) -> None:
    """Declare the ``spec`` form field of ``POST /v1/jobs`` as JSON text holding a ``Spec``."""
    schemas = schema["components"]["schemas"]
    spec = Spec.model_json_schema(ref_template="#/components/schemas/{model}")
    for name, sub in spec.pop("$defs", {}).items():
        schemas.setdefault(name, sub)
    schemas["Spec"] = spec
    body = schema["paths"]["/v1/jobs"]["post"]["requestBody"]["content"]["multipart/form-data"]
    form = schemas[body["schema"]["$ref"].rsplit("/", 1)[-1]]
    form["properties"]["spec"].update(
        contentMediaType="application/json", contentSchema={"$ref": "#/components/schemas/Spec"}
    )


def answer_options(router: APIRouter) -> None:
    """Add a documented ``OPTIONS`` operation to every path of a router (once).

    It answers 204 with an ``Allow`` header listing the path's methods.
    """
    allowed: dict[str, set[str]] = {}
    for route in router.routes:
        if isinstance(route, APIRoute):
            allowed.setdefault(route.path, set()).update(route.methods or ())
    for path, methods in allowed.items():
        if "OPTIONS" in methods:
            continue
        parameters = [
            {"name": name, "in": "path", "required": True, "schema": {"type": "string"}}
            for name in re.findall(r"{(\w+)}", path)
        ]
        router.add_api_route(
            path[len(router.prefix) :],
            _options(", ".join(sorted(methods | {"OPTIONS"}))),
            methods=["OPTIONS"],
            status_code=204,
            response_class=Response,
            summary="Methods of this path",
            responses={
                204: {
                    "description": "No body; the Allow header lists the methods.",
                    "headers": {"Allow": {"schema": {"type": "string"}}},
                },
                401: UNAUTHORIZED,
            },
            openapi_extra={"parameters": parameters} if parameters else None,
        )


def _options(allow: str) -> Callable[[Response], Awaitable[None]]:
    async def options(response: Response) -> None:
        response.headers["Allow"] = allow

    return options
