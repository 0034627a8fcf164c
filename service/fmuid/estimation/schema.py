"""The schema of a fit's JSON, and the one mechanism every result writes its JSON with.

A result class names its kind's pydantic model (``schema``); its ``to_dict`` (:class:`Written`)
builds that model from the object (:meth:`Block.of`) and dumps it. The model is thus the one
definition of the JSON: a field is written only when the model names it, and a block refuses a
field it does not name (``extra="forbid"``). The models of the other kinds sit beside their
result classes (``profiling.schema``, ``discrepancy.schema``, ``experiment_design.schema``);
:mod:`fmuid.results.schema` gathers them by kind.

Reading a file of another version (:func:`read_model`) drops the fields this version does not
name, with a warning, instead of refusing them.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any, ClassVar, Literal, Self

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, model_validator

if TYPE_CHECKING:
    from fmuid.estimation.result import FitResult

__all__ = ["SCHEMA_VERSION", "Block", "FitResultOut", "Written", "read_model"]

log = logging.getLogger(__name__)

SCHEMA_VERSION = 1
"""Version of the result JSON's schema, written as ``schema_version``.

Version 1 added ``kind`` and ``schema_version``; files without them are version 0 (read by
their keys). Raise it when a field changes meaning; adding a field keeps it.
"""

READING = "reading"
"""Validation context key: set when a saved file is read (unknown fields are dropped)."""

Interval = tuple[float | None, float | None]
"""A confidence interval; an end is null when the profile does not cross the threshold."""


def _is_none(value: object) -> bool:
    return value is None


def _is_empty(value: object) -> bool:
    return not value


def omitted_if_none(description: str = "") -> Any:
    """Return a field left out of the JSON when it is null (``None`` when absent)."""
    return Field(default=None, exclude_if=_is_none, description=description or None)


def omitted_if_empty(default: Any, description: str = "") -> Any:
    """Return a field left out of the JSON when it is empty (``default`` when absent)."""
    return Field(default=default, exclude_if=_is_empty, description=description or None)


class Block(BaseModel):
    """A block of a result's JSON: closed (a field it does not name is refused)."""

    model_config = ConfigDict(extra="forbid", from_attributes=True)

    @model_validator(mode="before")
    @classmethod
    def _known_fields(cls, data: Any, info: ValidationInfo) -> Any:
        """Drop the fields this version does not name when a saved file is read."""
        if not (info.context or {}).get(READING) or not isinstance(data, dict):
            return data
        unknown = sorted(set(data) - set(cls.model_fields))
        if unknown:
            log.warning("%s: fields of another version ignored: %s", cls.__name__, unknown)
        return {k: v for k, v in data.items() if k not in unknown}

    def fields(self) -> dict[str, Any]:
        """Return every field by name (those the JSON leaves out too): an object's arguments."""
        return {name: getattr(self, name) for name in type(self).model_fields}

    @classmethod
    def of(cls, obj: Any) -> Self:
        """Build the block from an object, by attribute name.

        A block whose JSON differs from its object's fields overrides it.
        """
        return cls.model_validate(obj, from_attributes=True)


class Written:
    """A result or block whose JSON is its schema's dump: ``to_dict`` is defined here only."""

    schema: ClassVar[type[Block]]
    """The pydantic model of the JSON."""

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form: the schema's model built from this object, dumped.

        A block keeps the fields it was given: one read from a dict of fewer fields (a file of
        an earlier version) writes those fields only.
        """
        return self.schema.of(self).model_dump(mode="json", exclude_unset=True)


def read_model(model: type[Block], data: Any) -> Any:
    """Validate a saved result's JSON against ``model``, dropping fields it does not name."""
    return model.model_validate(data, context={READING: True})


class FmuOut(Block):
    """The FMU a result was computed with, and how it was driven."""

    sha256: str
    model_name: str
    fmi_version: str | None = omitted_if_none()
    interface: str | None = omitted_if_none()
    input_handling: str | None = omitted_if_none()
    instances: str | None = omitted_if_none("How runs share FMU instances (reset or fresh).")

    @classmethod
    def of(cls, obj: Any) -> Self:
        """Build it from a fit (its sha256, model name and ``fmu_info``)."""
        return cls(sha256=obj.fmu_sha256, model_name=obj.model_name, **obj.fmu_info)


class CostOut(Block):
    """What a computation cost: FMU simulations and wall time in seconds (to the ms)."""

    simulations: int
    seconds: float

    @classmethod
    def of(cls, obj: Any) -> Self:
        """Build it from a :class:`~fmuid.estimation.result.Cost` (seconds rounded to ms)."""
        return cls(simulations=int(obj.simulations), seconds=round(float(obj.seconds), 3))


class ValidationOut(Block):
    """Held-out error of one test experiment and output (RMS in the output's unit)."""

    experiment: str
    output: str
    n: int
    rms_base: float
    rms_final: float | None = omitted_if_none("Of the final augmented model (diagnose only).")
    rms_by_step: list[float] = omitted_if_empty([], "After each step, the base first.")
    initial_states: dict[str, float] = omitted_if_empty(
        {}, "The record's per-experiment parameters, estimated on it (``Spec.per_experiment``)."
    )
    initial_states_final: dict[str, float] = omitted_if_empty({}, "The same, final model.")
    initial_states_method: str | None = omitted_if_none("How the initial states were obtained.")


class ProvenanceOut(Block):
    """How a result was made (docs/results.md); ``options`` and ``machine`` are free."""

    fmuid_version: str
    fmu_sha256: str
    seed: int | None = None
    options: dict[str, Any] = Field(default={}, description="The stage's options (free).")
    spec_sha256: str = ""
    data: list[dict[str, str]] = []
    started: str
    finished: str
    machine: dict[str, Any] = Field(default={}, description="Cores, platform, versions (free).")


class ResultBlock(Block):
    """What every result holds: its kind, the schema version, how it was made."""

    kind: str = Field(description="The result's kind (each kind's model fixes it).")
    schema_version: int = Field(
        default=SCHEMA_VERSION, description="Version of this schema the JSON was written with."
    )
    provenance: ProvenanceOut | None = omitted_if_none("How the result was made.")

    def model_post_init(self, context: Any, /) -> None:
        """Write ``kind`` and ``schema_version`` always (their defaults are the values)."""
        self.model_fields_set.update({"kind", "schema_version"})


class FitParameterOut(Block):
    """One free parameter of a fit."""

    estimate: float
    lower: float
    upper: float
    scale: Literal["log", "lin"] = "lin"
    unit: str = ""
    at_bound: bool = False


class EstimatedBlock(ResultBlock):
    """What a fit and a profile result share: the FMU, the data, the optimum, the cost."""

    fmu: FmuOut
    n_data: int
    chi2: float = Field(description="Weighted sum of squared residuals (thesis eq. 2.20).")
    sigma: dict[str, float]
    sigma_method: dict[str, str] = {}
    cost: CostOut
    units: dict[str, str] = {}
    validation: list[ValidationOut] = omitted_if_empty([], "Held-out errors (with test data).")

    @staticmethod
    def fields_of(fit: FitResult) -> dict[str, Any]:
        """Return the fields a fit and a profile share (a profile's cost is its own)."""
        return {
            "fmu": FmuOut.of(fit),
            "n_data": fit.n_data,
            "chi2": fit.chi2,
            "sigma": fit.sigma,
            "sigma_method": fit.sigma_method,
            "units": fit.units,
            "validation": [ValidationOut.of(v) for v in fit.validation],
        }


class FitResultOut(EstimatedBlock):
    """Result of a fit (``fmuid fit``, job kind ``fit``)."""

    kind: Literal["fit"] = "fit"
    parameters: dict[str, FitParameterOut]
    fixed: dict[str, float | str] = {}
    global_search: bool = True
    message: str = ""

    @classmethod
    def of(cls, obj: FitResult) -> Self:
        """Build it from a :class:`~fmuid.estimation.result.FitResult`."""
        on_bound = obj.space.at_bound(obj.z_estimate())
        return cls.model_validate(
            {
                **cls.fields_of(obj),
                "parameters": {
                    n: {
                        "estimate": obj.estimates[n],
                        "lower": obj.lower[n],
                        "upper": obj.upper[n],
                        "scale": s,
                        "unit": obj.units.get(n, ""),
                        "at_bound": n in on_bound,
                    }
                    for n, s in zip(obj.names, obj.scales, strict=True)
                },
                "fixed": obj.fixed,
                "global_search": obj.global_search,
                "message": obj.message,
                "cost": CostOut.of(obj.cost),
                "provenance": obj.provenance,
            }
        )
