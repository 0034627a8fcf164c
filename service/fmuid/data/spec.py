"""The study specification: free and fixed parameters, inputs, outputs and their sigma.

:class:`Spec` and its parts are pydantic models; a problem found while validating belongs to the
field path it names (``parameters.C_atf.lower: lower (5.0) must be below upper (2.0)``). Reading
the JSON text is :mod:`fmuid.data.spec_json`; checking a spec against an FMU and data is
:mod:`fmuid.data.checks`.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Self

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    FiniteFloat,
    PositiveFloat,
    PrivateAttr,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from fmuid.data.messages import show

__all__ = ["OutputSpec", "ParameterSpec", "PhysicsParameter", "PhysicsSpec", "Spec"]

Scale = Literal["log", "lin"]
"""Space in which a parameter is fitted: ``log`` (log10 of the value) or ``lin`` (the value)."""

_CONFIG = ConfigDict(extra="forbid", frozen=True, strict=True)


def _field_error(field: str, message: str) -> PydanticCustomError:
    """Return an error for a model validator that belongs to ``field`` (a dotted sub-path)."""
    return PydanticCustomError("spec", "{message}", {"field": field, "message": message})


class ParameterSpec(BaseModel):
    """A free parameter: start value and bounds, in the FMU's units.

    Parameters
    ----------
    start
        Start value of the fit; ``lower <= start <= upper``.
    lower, upper
        Bounds, ``lower < upper``, finite.
    scale
        ``"log"`` or ``"lin"``; by default log when ``lower > 0`` (see :attr:`resolved_scale`).

    """

    model_config = _CONFIG

    start: FiniteFloat
    lower: FiniteFloat
    upper: FiniteFloat
    scale: Scale | None = None

    @model_validator(mode="after")
    def _check_bounds(self) -> Self:
        if not self.lower < self.upper:
            raise _field_error(
                "lower", f"lower ({self.lower!r}) must be below upper ({self.upper!r})"
            )
        if not self.lower <= self.start <= self.upper:
            raise _field_error(
                "start",
                f"start ({self.start!r}) must lie within [lower, upper] = "
                f"[{self.lower!r}, {self.upper!r}]",
            )
        if self.scale == "log" and self.lower <= 0:
            raise _field_error(
                "scale", f"scale 'log' needs lower > 0 (lower is {self.lower!r}); use 'lin'"
            )
        return self

    @property
    def resolved_scale(self) -> Scale:
        """Fitting scale: ``scale`` when given, else ``"log"`` if ``lower > 0``, else ``"lin"``."""
        if self.scale is not None:
            return self.scale
        return "log" if self.lower > 0 else "lin"


class PhysicsParameter(ParameterSpec):
    """A parameter of switchable physics: fitted like a :class:`ParameterSpec` when switched on.

    Parameters
    ----------
    off
        The value that switches the effect off (the FMU's default behaviour).
    unit
        Unit of the value, for reports.
    description
        What the parameter means, for reports.

    """

    off: FiniteFloat
    unit: str = ""
    description: str = ""


class PhysicsSpec(BaseModel):
    """User-declared switchable physics of an FMU: the parameters of one effect."""

    model_config = _CONFIG

    parameters: dict[str, PhysicsParameter]
    description: str = ""

    @field_validator("parameters")
    @classmethod
    def _not_empty(cls, value: dict[str, PhysicsParameter]) -> dict[str, PhysicsParameter]:
        if not value:
            raise PydanticCustomError("spec", "an effect needs at least one parameter")
        return value


class OutputSpec(BaseModel):
    """A fitted output and its noise level.

    Parameters
    ----------
    sigma
        Standard deviation of the measurement noise in the output's unit (> 0), ``"column"``
        (per-sample values from the ``sigma_<output>`` column) or ``"estimate"`` (estimated
        from the data).

    """

    model_config = _CONFIG

    sigma: PositiveFloat | Literal["column", "estimate"]

    @field_validator("sigma", mode="before")
    @classmethod
    def _check_sigma(cls, value: Any) -> Any:
        if isinstance(value, str):
            ok = value in ("column", "estimate")
        else:
            number = isinstance(value, int | float) and not isinstance(value, bool)
            ok = number and math.isfinite(value) and value > 0
        if not ok:
            raise PydanticCustomError(
                "spec",
                "sigma must be a positive number, 'column' or 'estimate', not {value}",
                {"value": show(value)},
            )
        return value


class Spec(BaseModel):
    """A study: what is fitted, what is fixed, which inputs and outputs are used.

    Parameters
    ----------
    parameters
        Free parameters by FMU parameter name (at least one).
    fixed
        Start-value overrides of other FMU parameters (true/false or 0/1 for a Boolean, text
        for a String).
    inputs
        FMU inputs read from the data; empty means every data column that is an FMU input.
    outputs
        Fitted outputs by FMU output name (at least one).
    confidence
        Confidence level of the intervals, strictly between 0 and 1.
    global_search
        Whether a global search precedes the local fit.
    seed
        Seed of every random choice (non-negative).
    physics
        Switchable physics of the FMU by effect name (for the diagnosis).
    interface
        FMI interface to drive when the FMU has both: ``"auto"`` (co-simulation, the
        exporter's own solver), ``"co_simulation"`` or ``"model_exchange"`` (fmuid's CVode).
    settle
        Settle-in window [s]: every experiment's first ``settle`` seconds are simulated but
        left out of the likelihood and of the validation error (a real plant starts from an
        unknown state).
    per_experiment
        Free parameters that take one value per experiment (initial states an FMU exposes as
        parameters, e.g. ``x1_0``): each is fitted as ``<name>@<experiment file>`` with the
        bounds, scale and start of its entry in ``parameters``, and estimated on each test
        record as well (:mod:`fmuid.estimation.initial`).

    """

    model_config = _CONFIG

    parameters: dict[str, ParameterSpec]
    fixed: dict[str, FiniteFloat | bool | str] = {}
    inputs: list[str] = []
    outputs: dict[str, OutputSpec]
    confidence: Annotated[float, Field(gt=0, lt=1)] = 0.68
    global_search: bool = True
    seed: Annotated[int, Field(ge=0)] = 0
    physics: dict[str, PhysicsSpec] = {}
    interface: Literal["auto", "co_simulation", "model_exchange"] = "auto"
    settle: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 0.0
    per_experiment: list[str] = []

    _source: str = PrivateAttr(default="spec")

    @property
    def source(self) -> str:
        """Name of the file the spec was read from (``"spec"`` when built in code)."""
        return self._source

    @field_validator("parameters", "outputs")
    @classmethod
    def _not_empty(cls, value: dict[str, Any]) -> dict[str, Any]:
        if not value:
            raise PydanticCustomError("spec", "at least one entry is required")
        return value

    @model_validator(mode="after")
    def _check_names(self) -> Self:
        for name in self.fixed:
            if name in self.parameters:
                raise _field_error(f"fixed.{name}", f"'{name}' is both free and fixed")
        seen = {*self.parameters, *self.fixed}
        for effect, physics in self.physics.items():
            for name in physics.parameters:
                if name in seen:
                    raise _field_error(
                        f"physics.{effect}.parameters.{name}",
                        f"'{name}' is already a free, fixed or physics parameter",
                    )
                seen.add(name)
        for index, name in enumerate(self.inputs):
            if name in self.inputs[:index] or name in self.outputs:
                raise _field_error(f"inputs.{index}", f"'{name}' is listed twice or is an output")
        self._check_per_experiment(seen)
        return self

    def _check_per_experiment(self, names: set[str]) -> None:
        """Each ``per_experiment`` entry: a free parameter, listed once, its expansion unused."""
        for index, name in enumerate(self.per_experiment):
            field = f"per_experiment.{index}"
            if name in self.per_experiment[:index]:
                raise _field_error(field, f"'{name}' is listed twice")
            if name not in self.parameters:
                where = "fixed" if name in self.fixed else "not in parameters"
                raise _field_error(
                    field,
                    f"'{name}' is {where}: only a free parameter can take one value per "
                    "experiment (give it start, lower and upper in parameters)",
                )
            taken = sorted(n for n in names if n.startswith(f"{name}@"))
            if taken:
                raise _field_error(
                    field,
                    f"'{taken[0]}' is a parameter of its own, but would also name the value of "
                    f"'{name}' in experiment '{taken[0][len(name) + 1 :]}'",
                )
