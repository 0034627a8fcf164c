"""The schema of a profile result's JSON (``fmuid profile``, job kind ``profile``).

Each model is built from its object by :meth:`~fmuid.estimation.schema.Block.of` and dumped
by the object's ``to_dict`` (:class:`~fmuid.estimation.schema.Written`): the one definition
of the JSON.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Literal, Self

from pydantic import Field

from fmuid.estimation.schema import (
    Block,
    CostOut,
    EstimatedBlock,
    Interval,
    omitted_if_empty,
    omitted_if_none,
)

if TYPE_CHECKING:
    from fmuid.profiling.result import ParameterProfile, ProfileQuality, ProfileResult

Status = Literal["identifiable", "practically_non_identifiable", "structurally_non_identifiable"]


class IntervalsOut(Block):
    """Likelihood-based confidence intervals at both thresholds."""

    simultaneous: Interval
    pointwise: Interval


class ProfilePointOut(Block):
    """One point of a profile: the parameter fixed at ``value``, the others re-fitted."""

    value: float
    chi2: float | None = Field(description="Null where the point failed (see ``error``).")
    params: dict[str, float] = {}
    at_bound: list[str] = []
    error: str | None = omitted_if_none("Why the point failed.")

    @classmethod
    def of(cls, obj: Any) -> Self:
        """Build it from a :class:`~fmuid.profiling.result.ProfilePoint` (chi2 null if failed)."""
        return cls(
            value=obj.value,
            chi2=None if obj.error else obj.chi2,
            params=obj.params,
            at_bound=list(obj.at_bound),
            error=obj.error or None,
        )


class QualityOut(Block):
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

    @classmethod
    def of(cls, obj: ProfileQuality) -> Self:
        """Build it from a :class:`~fmuid.profiling.result.ProfileQuality`."""
        fields = dataclasses.asdict(obj)
        reasons = fields.pop("unsettled")
        return cls(**fields, unsettled=bool(reasons), unsettled_reasons=list(reasons))


class ProfileParameterOut(Block):
    """The profile of one free parameter."""

    estimate: float
    lower: float
    upper: float
    scale: Literal["log", "lin"] = "lin"
    ci: IntervalsOut
    status: Status
    status_reason: str = ""
    quality: QualityOut = QualityOut()
    profile: list[ProfilePointOut]
    limited_by: list[str] = omitted_if_empty([], "What bounds an open interval.")
    unit: str = ""

    @classmethod
    def of_profile(cls, obj: ParameterProfile, unit: str) -> Self:
        """Build it from a :class:`~fmuid.profiling.result.ParameterProfile` and its unit."""
        return cls(
            estimate=obj.estimate,
            lower=obj.lower,
            upper=obj.upper,
            scale=obj.scale,  # type: ignore[arg-type]
            ci=IntervalsOut(simultaneous=obj.ci_simultaneous, pointwise=obj.ci_pointwise),
            status=obj.status,  # type: ignore[arg-type]
            status_reason=obj.status_reason,
            quality=QualityOut.of(obj.quality),
            profile=[ProfilePointOut.of(p) for p in obj.points],
            limited_by=list(obj.limited_by),
            unit=unit,
        )


class ThresholdsOut(Block):
    """Chi-square thresholds of the intervals."""

    pointwise: float
    simultaneous: float


class CombinationOut(Block):
    """A null direction of the sensitivities: parameters only identifiable together."""

    parameters: list[str]
    direction: list[float] = []
    meaning: str = ""


class StructuralCheckOut(Block):
    """The numerical structural check of the noise-free sensitivities."""

    singular_values: list[float] = []
    non_identifiable_combinations: list[CombinationOut] = []


class HealthOut(Block):
    """The objective's health check before the profiles (:class:`~.health.Health`)."""

    smooth: bool
    deterministic: bool
    reset_matches_fresh: bool | None
    noise_floor: dict[str, float] = {}
    jumps: dict[str, int] = {}
    chi2_noise: dict[str, float] = {}
    noise_floor_chi2: float = 0.0
    diff_step: float
    simulations: int = 0
    no_effect: list[str] = []


class FitCheckOut(Block):
    """The multi-start check of the fit before the profiles."""

    starts: int = 0
    lower_found: bool = False
    simulations: int = 0
    valleys: int | None = omitted_if_none("Distinct valleys the walks started from.")


class CrossCheckOut(Block):
    """The branches checked against each other (:mod:`fmuid.profiling.cross`)."""

    ends: int = 0
    probes: int = 0
    resettled: int = 0
    simulations: int = 0


class ChecksOut(Block):
    """The checks made before the profiles (none in results of before 2026-10) and after."""

    health: HealthOut | None = omitted_if_none()
    fit: FitCheckOut | None = omitted_if_none()
    cross: CrossCheckOut | None = omitted_if_none(
        "Ends another parameter's points lay beyond, re-fits there, branches settled again."
    )


class ProfileResultOut(EstimatedBlock):
    """Result of a profile-likelihood study (``fmuid profile``, job kind ``profile``)."""

    kind: Literal["profile"] = "profile"
    confidence: float
    thresholds: ThresholdsOut
    parameters: dict[str, ProfileParameterOut]
    better_optimum_found: bool
    structural_check: StructuralCheckOut
    checks: ChecksOut = ChecksOut()

    @classmethod
    def of(cls, obj: ProfileResult) -> Self:
        """Build it from a :class:`~fmuid.profiling.result.ProfileResult`."""
        units = obj.fit.units
        return cls.model_validate(
            {
                **cls.fields_of(obj.fit),
                "confidence": obj.confidence,
                "thresholds": obj.thresholds,
                "parameters": {
                    n: ProfileParameterOut.of_profile(p, units.get(n, ""))
                    for n, p in obj.parameters.items()
                },
                "better_optimum_found": obj.better_optimum_found,
                "structural_check": obj.structural_check,
                "checks": obj.checks,
                "cost": CostOut.of(obj.cost),
                "provenance": obj.provenance,
            }
        )
