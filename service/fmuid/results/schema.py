"""The one typed schema of each result's JSON: fit, profile, diagnose, design.

Each kind is a pydantic model of the JSON that the result's ``to_dict`` writes; the same model
reads it back (:mod:`fmuid.results`), is the response model of ``GET /v1/jobs/{id}/result``
(:mod:`fmuid.api.results`) and gives the published JSON Schema
(``python -m fmuid.results KIND``). Every JSON carries ``kind`` and ``schema_version``
(:data:`SCHEMA_VERSION`); a file written before they existed is read by its keys
(:func:`fmuid.results.kind_of`). Every model allows more fields than it names: the engine adds
diagnostics (a profile's ``checks``, a design's stage times) that a reader may keep untyped.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from fmuid.estimation.result import SCHEMA_VERSION

__all__ = ["KINDS", "SCHEMA_VERSION", "json_schema"]

Interval = tuple[float | None, float | None]
"""A confidence interval; an end is null when the profile does not cross the threshold."""


class _Open(BaseModel):
    """A block of a result: the fields named are typed, others are kept as they are."""

    model_config = ConfigDict(extra="allow")


class FmuOut(_Open):
    """The FMU a result was computed with, and how it was driven."""

    sha256: str
    model_name: str
    fmi_version: str | None = None
    interface: str | None = None
    input_handling: str | None = None


class CostOut(_Open):
    """What a computation cost: FMU simulations and wall time in seconds."""

    simulations: int
    seconds: float


class StageCostOut(CostOut):
    """What one step of a diagnosis cost (``stage``: e.g. ``scan``, ``profiles``)."""

    stage: str


class DiagnosisCostOut(CostOut):
    """What a diagnosis cost, and each of its steps in order (they sum to the total)."""

    stages: list[StageCostOut] = Field(
        default=[], description="The cost of each step (none in results of before 2026-11)."
    )


class ValidationOut(_Open):
    """Held-out error of one test experiment and output (RMS in the output's unit)."""

    experiment: str
    output: str
    n: int
    rms_base: float
    rms_final: float | None = None
    rms_by_step: list[float] | None = None


class _Result(_Open):
    """What every result holds: its kind, the schema version, how it was made."""

    schema_version: int = Field(description="Version of this schema the JSON was written with.")
    provenance: dict[str, Any] | None = Field(
        default=None, description="How the result was made (docs/results.md)."
    )


class FitParameterOut(_Open):
    """One free parameter of a fit."""

    estimate: float
    lower: float
    upper: float
    scale: Literal["log", "lin"] = "lin"
    unit: str = ""
    at_bound: bool = False


class _Estimated(_Result):
    """What a fit and a profile result share: the FMU, the data, the optimum, the cost."""

    fmu: FmuOut
    n_data: int
    chi2: float = Field(description="Weighted sum of squared residuals (thesis eq. 2.20).")
    sigma: dict[str, float]
    sigma_method: dict[str, str] = {}
    cost: CostOut
    units: dict[str, str] = {}
    validation: list[ValidationOut] | None = None


class FitResultOut(_Estimated):
    """Result of a fit (``fmuid fit``, job kind ``fit``)."""

    kind: Literal["fit"]
    parameters: dict[str, FitParameterOut]
    fixed: dict[str, float | str] = {}
    global_search: bool = True
    message: str = ""


class IntervalsOut(_Open):
    """Likelihood-based confidence intervals at both thresholds."""

    simultaneous: Interval
    pointwise: Interval


class ProfilePointOut(_Open):
    """One point of a profile: the parameter fixed at ``value``, the others re-fitted."""

    value: float
    chi2: float | None = Field(description="Null where the point failed (see ``error``).")
    params: dict[str, float] = {}
    at_bound: list[str] = []
    error: str | None = None


class QualityOut(_Open):
    """How a profile was checked (docs/profiles.md)."""

    checks: int = 0
    starts: int = 0
    jumps: int = 0
    lower_valleys: int = 0
    rewalks: int = 0
    end_refits: int = 0
    unsettled: bool = False
    unsettled_reasons: list[str] = []
    check_simulations: int = 0


class ProfileParameterOut(FitParameterOut):
    """The profile of one free parameter."""

    ci: IntervalsOut
    status: Literal["identifiable", "practically_non_identifiable", "structurally_non_identifiable"]
    status_reason: str = ""
    quality: QualityOut = QualityOut()
    profile: list[ProfilePointOut]
    limited_by: list[str] | None = None


class ThresholdsOut(_Open):
    """Chi-square thresholds of the intervals."""

    pointwise: float
    simultaneous: float


class CombinationOut(_Open):
    """A null direction of the sensitivities: parameters only identifiable together."""

    parameters: list[str]
    direction: list[float] = []
    meaning: str = ""


class StructuralCheckOut(_Open):
    """The numerical structural check of the noise-free sensitivities."""

    singular_values: list[float] = []
    non_identifiable_combinations: list[CombinationOut] = []


class ProfileResultOut(_Estimated):
    """Result of a profile-likelihood study (``fmuid profile``, job kind ``profile``)."""

    kind: Literal["profile"]
    confidence: float
    thresholds: ThresholdsOut
    parameters: dict[str, ProfileParameterOut]
    better_optimum_found: bool
    structural_check: StructuralCheckOut
    checks: dict[str, Any] = {}


class EvidenceOut(_Open):
    """One residual test."""

    test: str
    output: str | None = None
    experiment: str | None = None
    p_value: float


class DiagnosisOut(_Result):
    """Result of a diagnosis (``fmuid diagnose``, job kind ``diagnose``)."""

    kind: Literal["diagnose"]
    verdict: str = ""
    mismatch: bool
    evidence: list[EvidenceOut] = []
    location: dict[str, Any] = {}
    effect: str | None = None
    description: str = ""
    candidates: list[dict[str, Any]] = []
    added_parameters: dict[str, Any] = {}
    chi2_before: float
    chi2_after: float
    parameters: dict[str, Any] = {}
    cost: DiagnosisCostOut | None = None


class DesignExperimentOut(_Open):
    """A test: the input family and its settings, duration [s], sampling rate, sensors."""

    input: str
    input_variable: str
    settings: dict[str, float]
    duration: float
    rate_hz: float
    outputs: list[str]
    fixed: dict[str, float] = {}


class PredictedOut(_Open):
    """A parameter's interval and label predicted from the Fisher information."""

    ci: Interval
    status: str
    width: float | None = Field(default=None, description="Interval width (decades for log).")


class VerifiedOut(_Open):
    """Profiles on simulated data of a design: draws, and how often each parameter was settled."""

    draws: int
    identifiable: dict[str, int]
    open_ended: dict[str, int] = {}
    median_width: dict[str, float | None] = {}
    width_unit: str = ""


class DesignOut(_Open):
    """One ranked design."""

    experiment: DesignExperimentOut
    predicted: dict[str, PredictedOut]
    verified: VerifiedOut | None
    score: float | None
    cost: dict[str, float] = {}


class NotIdentifiableOut(_Open):
    """Parameters no feasible design identifies apart."""

    parameters: list[str]
    meaning: str


class DesignResultOut(_Result):
    """Result of an experiment design (``fmuid design``, job kind ``design``)."""

    kind: Literal["design"]
    fmu: FmuOut
    criterion: Literal["D", "E"]
    designs: list[DesignOut]
    not_identifiable_by_any: list[NotIdentifiableOut]
    tradeoffs: dict[str, Any] = {}
    screened: int = 0
    cost: CostOut


KINDS: dict[str, type[_Result]] = {
    "fit": FitResultOut,
    "profile": ProfileResultOut,
    "diagnose": DiagnosisOut,
    "design": DesignResultOut,
}
"""The schema of each result kind, by the ``kind`` its JSON carries."""

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
