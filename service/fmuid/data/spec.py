"""The study specification (JSON): free and fixed parameters, inputs, outputs and their sigma.

:func:`load_spec` and :func:`spec_from_json` turn the file into a validated :class:`Spec`;
every problem becomes one line of a :class:`~fmuid.errors.SpecError` naming the file and the
field path (``spec.json: parameters.C_atf.lower: lower (5.0) must be below upper (2.0)``).
:func:`check_against_model` then checks the spec and the experiments against the names an FMU
declares, without depending on the FMU code.
"""

from __future__ import annotations

import difflib
import json
import math
import os
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal, Self, get_args, get_origin

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    FiniteFloat,
    PositiveFloat,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from fmuid.data.experiment import Experiment
from fmuid.errors import DataError, SpecError

__all__ = [
    "OutputSpec",
    "ParameterSpec",
    "PhysicsParameter",
    "PhysicsSpec",
    "Spec",
    "check_against_model",
    "load_spec",
    "spec_from_json",
    "used_inputs",
]

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
                {"value": _show(value)},
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
        return self


def load_spec(path: str | os.PathLike[str]) -> Spec:
    """Read and validate a spec file (JSON, UTF-8).

    Parameters
    ----------
    path
        The JSON file.

    Returns
    -------
    Spec
        The validated spec; its :attr:`Spec.source` is the file's base name.

    Raises
    ------
    SpecError
        Naming the file and, one line per problem, the field path at fault.

    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SpecError(f"{path.name}: file not found ({path})") from None
    except OSError as error:
        raise SpecError(f"{path.name}: cannot read the file ({error.strerror})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise SpecError(f"{path.name}: not UTF-8 text (byte {error.start})") from None
    return spec_from_json(text, source=path.name)


def spec_from_json(text: str, source: str = "spec") -> Spec:
    """Validate a spec given as JSON text.

    Parameters
    ----------
    text
        The JSON document.
    source
        Name used in error messages and kept as :attr:`Spec.source` (the file name).

    Returns
    -------
    Spec
        The validated spec.

    Raises
    ------
    SpecError
        For invalid JSON (with line and column) or invalid content (one line per problem,
        each naming the field path).

    """
    if not text.strip():
        raise SpecError(f"{source}: file is empty")

    def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        keys = [key for key, _ in pairs]
        for key in keys:
            if keys.count(key) > 1:
                raise SpecError(f"{source}: key '{key}' appears twice in one object")
        return dict(pairs)

    try:
        data = json.loads(text, object_pairs_hook=unique_keys)
    except json.JSONDecodeError as error:
        raise SpecError(
            f"{source}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}"
        ) from None
    if not isinstance(data, dict):
        kinds = {list: "an array", str: "a string", bool: "a boolean", type(None): "null"}
        kind = kinds.get(type(data), "a number")
        raise SpecError(f"{source}: the spec must be a JSON object, got {kind}")
    try:
        spec = Spec.model_validate(data)
    except ValidationError as error:
        raise SpecError(_format_errors(source, error)) from None
    spec._source = source
    return spec


def _format_errors(source: str, error: ValidationError) -> str:
    """One line ``source: field.path: problem`` per pydantic error."""
    lines = []
    for item in error.errors(include_url=False):
        loc: list[str | int] = list(item["loc"])
        context = item.get("ctx") or {}
        if "field" in context:
            loc += [int(p) if p.isdigit() else p for p in str(context["field"]).split(".")]
        if item["type"] == "extra_forbidden":
            message = _unknown_field(loc)
        elif item["type"] == "missing":
            message = "required field is missing"
        elif item["type"] == "spec":
            message = item["msg"]
        else:
            message = f"{item['msg']} (got {_show(item['input'])})"
        lines.append(f"{source}: {_path(loc)}: {message}")
    return "\n".join(lines)


def _path(loc: Sequence[str | int]) -> str:
    """Render a location as ``parameters.C_atf.lower`` / ``inputs[0]``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else f".{part}"
    return text.lstrip(".") or "(top level)"


def _unknown_field(loc: Sequence[str | int]) -> str:
    """Explain an unknown key, suggesting the allowed field names."""
    annotation: Any = Spec
    for part in loc[:-1]:
        if get_origin(annotation) in (dict, list):
            annotation = get_args(annotation)[-1]
        else:
            annotation = annotation.model_fields[part].annotation
    allowed = list(annotation.model_fields)
    return f"unknown field{_suggest(str(loc[-1]), allowed, 'fields')}"


def _suggest(name: str, candidates: Collection[str], what: str) -> str:
    """Return `` (did you mean 'x'?)`` or `` (<what>: a, b, ...)`` for a message."""
    folded = {candidate.casefold(): candidate for candidate in candidates}
    matches = difflib.get_close_matches(name.casefold(), list(folded), n=3, cutoff=0.5)
    close = [folded[match] for match in matches]
    if close:
        return f" (did you mean {' or '.join(repr(c) for c in close)}?)"
    names = sorted(candidates)
    shown = ", ".join(names[:30]) + (", ..." if len(names) > 30 else "")
    return f" ({what}: {shown or 'none'})"


def _show(value: Any, limit: int = 60) -> str:
    """Render an input value as JSON text for a message."""
    text = json.dumps(value, default=str)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def used_inputs(spec: Spec, fmu_inputs: Collection[str], experiment: Experiment) -> list[str]:
    """Return the FMU inputs that an experiment drives.

    Parameters
    ----------
    spec
        The study; its ``inputs`` win when not empty.
    fmu_inputs
        Names of the FMU's inputs.
    experiment
        The experiment; without spec inputs, its columns that are FMU inputs are used.

    Returns
    -------
    list of str
        Input names, in spec order or else in column order.

    """
    if spec.inputs:
        return list(spec.inputs)
    return [column for column in experiment.columns if column in fmu_inputs]


def check_against_model(
    spec: Spec,
    parameters: Collection[str],
    inputs: Collection[str],
    outputs: Collection[str],
    experiments: Sequence[Experiment],
) -> None:
    """Check that the spec and the experiments fit an FMU's variables.

    Parameters
    ----------
    spec
        The validated spec.
    parameters, inputs, outputs
        Names of the FMU's parameters, inputs and outputs.
    experiments
        The loaded experiments.

    Raises
    ------
    SpecError
        A free, fixed or physics parameter, an input or an output the FMU does not have
        (every such problem, one per line).
    DataError
        A data column that the FMU does not know, a spec input missing from a file, a spec
        output without data, or sigma columns that do not give a positive value for every
        sample (every such problem, one per line, naming file, row and column).

    """
    problems = []
    groups: list[tuple[str, Collection[str]]] = [
        ("parameters", spec.parameters),
        ("fixed", spec.fixed),
    ]
    for effect, physics in spec.physics.items():
        groups.append((f"physics.{effect}.parameters", physics.parameters))
    for field, names in groups:
        problems += [
            f"{spec.source}: {field}.{name}: the FMU has no parameter '{name}'"
            f"{_suggest(name, parameters, 'its parameters')}"
            for name in names
            if name not in parameters
        ]
    named = (("inputs", spec.inputs, inputs), ("outputs", spec.outputs, outputs))
    for field, names, known in named:
        problems += [
            f"{spec.source}: {field}: the FMU has no {field[:-1]} '{name}'"
            f"{_suggest(name, known, f'its {field}')}"
            for name in names
            if name not in known
        ]
    if problems:
        raise SpecError("\n".join(problems))
    for experiment in experiments:
        problems += _experiment_problems(spec, inputs, outputs, experiment)
    files = ", ".join(experiment.name for experiment in experiments) or "no data file"
    problems += [
        f"output '{name}' (spec) has no column in any data file ({files})"
        for name in spec.outputs
        if not any(name in experiment.columns for experiment in experiments)
    ]
    if problems:
        raise DataError("\n".join(problems))


def _experiment_problems(
    spec: Spec, inputs: Collection[str], outputs: Collection[str], experiment: Experiment
) -> list[str]:
    """Problems of one experiment against the spec and the FMU's inputs and outputs."""
    name = experiment.name
    known = [*inputs, *outputs, *(f"sigma_{output}" for output in outputs)]
    problems = [
        f"{name}: row 1, column '{column}': not an input or output of the FMU"
        f"{_suggest(column, known, 'allowed besides time')}"
        for column in experiment.columns
        if column not in known
    ]
    for column in used_inputs(spec, inputs, experiment):
        if column not in experiment.columns:
            problems.append(f"{name}: column '{column}' is missing (the spec lists it in inputs)")
        elif np.isnan(experiment.columns[column]).all():
            problems.append(f"{name}: column '{column}': the input has no value in any row")
    for output, output_spec in spec.outputs.items():
        if output not in experiment.columns:
            continue
        mask = experiment.output_mask(output)
        if not mask.any():
            problems.append(f"{name}: column '{output}': the output has no value in any row")
        if output_spec.sigma != "column":
            continue
        sigma = experiment.sigma_column(output)
        column = f"sigma_{output}"
        if sigma is None:
            problems.append(
                f"{name}: column '{column}' is missing (outputs.{output}.sigma is 'column')"
            )
            continue
        empty = np.flatnonzero(mask & np.isnan(sigma))
        if empty.size:
            problems.append(
                f"{name}: row {empty[0] + 2}, column '{column}': empty, "
                f"but '{output}' has a value in this row"
            )
        bad = np.flatnonzero(sigma <= 0)
        if bad.size:
            problems.append(
                f"{name}: row {bad[0] + 2}, column '{column}': sigma must be positive, "
                f"got {float(sigma[bad[0]])!r}"
            )
    return problems
