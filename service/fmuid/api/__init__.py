"""The HTTP API of fmuid: FastAPI app, routers and request/response schemas."""

from fmuid.api.app import create_app, serve

__all__ = ["create_app", "serve"]
