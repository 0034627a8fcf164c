"""The one typed schema of each result's JSON, by kind: fit, profile, diagnose, design.

Each kind is a pydantic model that sits beside its result class
(:mod:`fmuid.estimation.schema`, :mod:`fmuid.profiling.schema`, :mod:`fmuid.discrepancy.schema`,
:mod:`fmuid.experiment_design.schema`): the class's ``to_dict`` is that model built from the
object and dumped (:class:`fmuid.estimation.schema.Written`), so the model is the only place
the JSON's shape is written. The same model reads the JSON back (:mod:`fmuid.results`), is the
response model of ``GET /v1/jobs/{id}/result`` (:mod:`fmuid.api.results`) and gives the
published JSON Schema (``python -m fmuid.results KIND``). Every JSON carries ``kind`` and
``schema_version`` (:data:`SCHEMA_VERSION`); a file written before they existed is read by its
keys (:func:`fmuid.results.kind_of`). Every block is closed: a field it does not name is refused
when written; a file of another version is read without the fields this one does not name.
"""

from __future__ import annotations

from typing import Any

from fmuid.discrepancy.result import Diagnosis
from fmuid.discrepancy.schema import DiagnosisOut
from fmuid.estimation.result import FitResult
from fmuid.estimation.schema import SCHEMA_VERSION, FitResultOut, ResultBlock
from fmuid.experiment_design.result import DesignResult
from fmuid.experiment_design.schema import DesignResultOut
from fmuid.profiling.result import ProfileResult
from fmuid.profiling.schema import ProfileResultOut

__all__ = [
    "KINDS",
    "RESULTS",
    "SCHEMA_VERSION",
    "DesignResultOut",
    "DiagnosisOut",
    "FitResultOut",
    "ProfileResultOut",
    "ResultOut",
    "json_schema",
]

KINDS: dict[str, type[ResultBlock]] = {
    "fit": FitResultOut,
    "profile": ProfileResultOut,
    "diagnose": DiagnosisOut,
    "design": DesignResultOut,
}
"""The schema of each result kind, by the ``kind`` its JSON carries."""

RESULTS: dict[str, type[Any]] = {
    "fit": FitResult,
    "profile": ProfileResult,
    "diagnose": Diagnosis,
    "design": DesignResult,
}
"""The result class of each kind (its ``schema`` is ``KINDS[kind]``)."""

ResultOut = ProfileResultOut | FitResultOut | DiagnosisOut | DesignResultOut
"""Any result (the ``kind`` field says which)."""


def json_schema(kind: str) -> dict[str, Any]:
    """Return the JSON Schema of one result kind (``fit``, ``profile``, ``diagnose``, ``design``).

    Raises
    ------
    KeyError
        If ``kind`` is none of them.

    """
    return KINDS[kind].model_json_schema()
