"""OpenAPI models of the result JSON (``GET /v1/jobs/{id}/result``), for generated clients.

They are the results' own schemas (:mod:`fmuid.results.schema`): the one definition that the
engine's results are read back with. The service sends the stored JSON as it is; these models
document it in ``/openapi.json``.
"""

from __future__ import annotations

from fmuid.results.schema import (
    DesignResultOut,
    DiagnosisOut,
    FitResultOut,
    ProfileResultOut,
    ResultOut,
)

__all__ = ["DesignResultOut", "DiagnosisOut", "FitResultOut", "ProfileResultOut", "ResultOut"]
