"""OpenAPI models of the result JSON (``GET /v1/jobs/{id}/result``), for generated clients.

They describe the fields ``../shared/CONTRACT.md`` fixes for each kind of job; every model
allows more fields (the engine adds diagnostics such as ``quality`` or ``checks``), so a client
reads the documented ones typed and keeps the rest. The service sends the stored JSON as it is:
these models only document it.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

_OPEN = ConfigDict(extra="allow")


class FmuOut(BaseModel):
    """The FMU a result was computed with."""

    model_config = _OPEN
    sha256: str
    model_name: str


class CostOut(BaseModel):
    """What a computation cost."""

    model_config = _OPEN
    simulations: int
    seconds: float


class FitParameterOut(BaseModel):
    """One free parameter of a fit."""

    model_config = _OPEN
    estimate: float
    lower: float
    upper: float


class IntervalsOut(BaseModel):
    """Likelihood-based confidence intervals; an end is null when it is not crossed."""

    model_config = _OPEN
    simultaneous: list[float | None]
    pointwise: list[float | None]


class ProfilePointOut(BaseModel):
    """One point of a profile: the parameter fixed at ``value``, the others re-fitted."""

    model_config = _OPEN
    value: float
    chi2: float | None
    params: dict[str, float] = {}
    at_bound: list[str] = []


class ProfileParameterOut(FitParameterOut):
    """The profile of one free parameter."""

    ci: IntervalsOut
    status: Literal["identifiable", "practically_non_identifiable", "structurally_non_identifiable"]
    profile: list[ProfilePointOut]
    limited_by: list[str] | None = None


class _EstimatedOut(BaseModel):
    """What a fit and a profile result share: the FMU, the data, the optimum, the cost."""

    model_config = _OPEN
    fmu: FmuOut
    n_data: int
    chi2: float = Field(description="Weighted sum of squared residuals.")
    sigma: dict[str, float]
    cost: CostOut


class FitResultOut(_EstimatedOut):
    """Result of a ``fit`` job."""

    parameters: dict[str, FitParameterOut]


class ThresholdsOut(BaseModel):
    """Chi-square thresholds of the intervals."""

    model_config = _OPEN
    pointwise: float
    simultaneous: float


class ProfileResultOut(_EstimatedOut):
    """Result of a ``profile`` job."""

    confidence: float
    thresholds: ThresholdsOut
    parameters: dict[str, ProfileParameterOut]
    better_optimum_found: bool
    structural_check: dict[str, Any]


class DiagnosisOut(BaseModel):
    """Result of a ``diagnose`` job."""

    model_config = _OPEN
    mismatch: bool
    evidence: list[dict[str, Any]]
    location: dict[str, Any] | None
    effect: str | None
    description: str
    candidates: list[dict[str, Any]]
    added_parameters: dict[str, Any]
    chi2_before: float | None
    chi2_after: float | None
    parameters: dict[str, Any]


class DesignResultOut(BaseModel):
    """Result of a ``design`` job."""

    model_config = _OPEN
    designs: list[dict[str, Any]]
    not_identifiable_by_any: list[dict[str, Any]]
    cost: CostOut


ResultOut = ProfileResultOut | FitResultOut | DiagnosisOut | DesignResultOut
"""Any result, by the job's kind."""
