"""The experiment space (``E.json``): which tests are feasible, what they measure and how well.

```json
{"input": "delta",
 "families": {"step": {"amplitude": [0.05, 0.17], "time": [0.5, 3]},
              "chirp": {"f0": [0.05, 0.5], "f1": [0.5, 2], "amplitude": [0.05, 0.17]}},
 "duration": [5, 10], "rates_hz": [5, 10],
 "outputs": {"gam_t": {"sigma": 0.0116}, "gam_i": {"sigma": 0.0116}, "y_tc": {"sigma": 0.02}},
 "base_outputs": ["gam_t", "gam_i"], "max_sensors": 3,
 "fixed": {"u_tc": [3, 6]}, "longest_test": 10}
```
Each family setting is a ``[lower, upper]`` range (or one number: held at that value).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal, Self

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PositiveFloat,
    ValidationError,
    field_validator,
    model_validator,
)

from fmuid.errors import SpecError

FAMILY_SETTINGS: dict[str, tuple[str, ...]] = {
    "step": ("amplitude", "time"),
    "ramp": ("amplitude", "start", "rise"),
    "chirp": ("f0", "f1", "amplitude"),
    "multisine": ("f_min", "f_max", "amplitude", "tones"),
    "double_lane_change": ("amplitude", "duration"),
}
"""Input families and the names of their settings (see :mod:`fmuid.experiment_design.signals`)."""

Range = tuple[float, float]


def _range(value: Any) -> Range:
    if isinstance(value, int | float) and not isinstance(value, bool):
        value = [value, value]
    if (
        not isinstance(value, list | tuple)
        or len(value) != 2
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        or not all(math.isfinite(v) for v in value)
    ):
        raise ValueError(f"must be a number or [lower, upper] of finite numbers, not {value!r}")
    lo, hi = float(value[0]), float(value[1])
    if lo > hi:
        raise ValueError(f"lower {lo!r} is above upper {hi!r}")
    return lo, hi


class OutputNoise(BaseModel):
    """Noise of a candidate sensor: standard deviation in the output's unit."""

    model_config = ConfigDict(extra="forbid")
    sigma: PositiveFloat


class RobustBox(BaseModel):
    """Where the screen looks for the worst case: ``points`` Latin-hypercube points of ``box``.

    ``box`` maps a free parameter to ``[lower, upper]``; the default is the spec's bounds.
    The nominal (the spec's start) is always one of the points.
    """

    model_config = ConfigDict(extra="forbid")
    points: Annotated[int, Field(ge=0, le=64)] = 4
    box: dict[str, Range] = {}

    @field_validator("box", mode="before")
    @classmethod
    def _ranges(cls, value: Any) -> Any:
        if isinstance(value, dict):
            return {k: _range(v) for k, v in value.items()}
        return value


class Space(BaseModel):
    """The feasible experiments of a design study (the ``E.json`` file).

    Attributes
    ----------
    input
        The FMU input the test drives.
    families
        Input family -> setting -> ``[lower, upper]`` (see :data:`FAMILY_SETTINGS`).
    duration
        Test duration range [s]; capped by ``longest_test``.
    rates_hz
        Sampling rates the sensors may run at [Hz].
    outputs
        Candidate sensors (FMU outputs) with their noise.
    base_outputs
        Sensors every design has (default: all of ``outputs`` when ``max_sensors`` is absent).
    max_sensors
        Most sensors in one design (default: all candidates).
    fixed
        FMU parameters the test may set -> ``[lower, upper]`` (e.g. forward speed).
    longest_test
        Longest feasible test [s] (default: the upper end of ``duration``); a design's
        interval widths are weighed by ``sqrt(duration / longest_test)``.
    criterion
        ``"D"`` (geometric mean of the confidence ellipsoid's axes) or ``"E"`` (its longest axis).
    robust
        Prior box of the worst-case screen.
    candidates
        Designs sampled per input family in the screen.
    verify_designs, draws
        Best designs checked by profiles, and noise draws each.
    seed
        Seed of the candidate sampling and the noise.

    """

    model_config = ConfigDict(extra="forbid")

    input: str
    families: dict[str, dict[str, Range]]
    duration: Range
    rates_hz: list[PositiveFloat] = Field(min_length=1)
    outputs: dict[str, OutputNoise] = Field(min_length=1)
    base_outputs: list[str] = []
    max_sensors: Annotated[int, Field(ge=1)] | None = None
    fixed: dict[str, Range] = {}
    longest_test: PositiveFloat
    criterion: Literal["D", "E"] = "D"
    robust: RobustBox = RobustBox()
    candidates: Annotated[int, Field(ge=1, le=10000)] = 24
    verify_designs: Annotated[int, Field(ge=0, le=20)] = 2
    draws: Annotated[int, Field(ge=1, le=100)] = 5
    seed: Annotated[int, Field(ge=0)] = 0

    @model_validator(mode="before")
    @classmethod
    def _longest_test(cls, data: Any) -> Any:
        """Default ``longest_test`` to the longest duration asked for."""
        if isinstance(data, dict) and "longest_test" not in data and "duration" in data:
            try:
                return {**data, "longest_test": _range(data["duration"])[1]}
            except ValueError:  # the duration's own error is reported
                return data
        return data

    @field_validator("duration", mode="before")
    @classmethod
    def _duration(cls, value: Any) -> Any:
        return _range(value)

    @field_validator("fixed", mode="before")
    @classmethod
    def _fixed(cls, value: Any) -> Any:
        if isinstance(value, dict):
            return {k: _range(v) for k, v in value.items()}
        return value

    @field_validator("families", mode="before")
    @classmethod
    def _families(cls, value: Any) -> Any:
        if not isinstance(value, dict) or not value:
            raise ValueError("must name at least one input family")
        out = {}
        for family, settings in value.items():
            if family not in FAMILY_SETTINGS:
                raise ValueError(f"unknown family {family!r}; known: {', '.join(FAMILY_SETTINGS)}")
            if not isinstance(settings, dict):
                raise ValueError(f"{family}: settings must be an object")
            needed = FAMILY_SETTINGS[family]
            unknown = sorted(set(settings) - set(needed))
            missing = [s for s in needed if s not in settings]
            if unknown or missing:
                raise ValueError(
                    f"{family}: settings are {', '.join(needed)}"
                    + (f"; unknown: {', '.join(unknown)}" if unknown else "")
                    + (f"; missing: {', '.join(missing)}" if missing else "")
                )
            ranges = {}
            for name, v in settings.items():
                try:
                    ranges[name] = _range(v)
                except ValueError as exc:
                    raise ValueError(f"{family}.{name} {exc}") from None
            out[family] = ranges
        return out

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if self.duration[0] <= 0 or self.duration[1] > self.longest_test:
            raise ValueError(
                f"duration: {list(self.duration)} must be positive and at most longest_test "
                f"({self.longest_test:g} s)"
            )
        unknown = [o for o in self.base_outputs if o not in self.outputs]
        if unknown:
            raise ValueError(f"base_outputs: {unknown} are not among outputs")
        if self.max_sensors is not None and self.max_sensors < max(1, len(self.base_outputs)):
            raise ValueError(
                f"max_sensors: {self.max_sensors} is below the {len(self.base_outputs)} "
                "base_outputs"
            )
        for family, ranges in self.families.items():
            for name, (lo, _) in ranges.items():
                if name in ("f0", "f1", "f_min", "f_max", "rise", "duration", "tones") and lo <= 0:
                    raise ValueError(f"families.{family}.{name}: must be positive")
        return self

    def sensor_sets(self) -> list[tuple[str, ...]]:
        """Every sensor set a design may have: the base sensors plus up to ``max_sensors``."""
        from itertools import combinations

        base = tuple(self.base_outputs)
        if self.max_sensors is None:
            return [base] if base else [tuple(self.outputs)]
        extra = [o for o in self.outputs if o not in base]
        sets: list[tuple[str, ...]] = []
        for k in range(0, self.max_sensors - len(base) + 1):
            sets.extend(base + combo for combo in combinations(extra, k))
        return [s for s in sets if s]


def space_from_json(text: str, source: str = "space") -> Space:
    """Validate an experiment space given as JSON text.

    Raises
    ------
    SpecError
        For invalid JSON or content; each line names the field path.

    """
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise SpecError(
            f"{source}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}"
        ) from None
    if not isinstance(data, dict):
        raise SpecError(f"{source}: the experiment space must be a JSON object")
    try:
        return Space.model_validate(data)
    except ValidationError as error:
        lines = []
        for item in error.errors():
            path = ".".join(str(p) for p in item["loc"]) or "(top level)"
            message = str(item["msg"]).removeprefix("Value error, ")
            lines.append(f"{source}: {path}: {message}")
        raise SpecError("\n".join(lines)) from None


def load_space(path: str | os.PathLike[str]) -> Space:
    """Read and validate an ``E.json`` file (errors name the file and the field)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise SpecError(f"{path}: cannot read the experiment space: {exc.strerror}") from None
    return space_from_json(text, path.name)


def check_space(
    space: Space,
    inputs: Sequence[str],
    outputs: Sequence[str],
    parameters: Mapping[str, object],
    free: Sequence[str],
) -> None:
    """Check the space against the FMU's variables and the spec's free parameters.

    Raises
    ------
    SpecError
        Naming the field and the unknown name.

    """
    problems = []
    if space.input not in inputs:
        problems.append(f"input: {space.input!r} is not an FMU input ({', '.join(inputs)})")
    problems += [
        f"outputs: {o!r} is not an FMU output ({', '.join(outputs)})"
        for o in space.outputs
        if o not in outputs
    ]
    problems += [
        f"fixed: {p!r} is not an FMU parameter" for p in space.fixed if p not in parameters
    ]
    problems += [f"fixed: {p!r} is a free parameter of the spec" for p in space.fixed if p in free]
    problems += [
        f"robust.box: {p!r} is not a free parameter of the spec"
        for p in space.robust.box
        if p not in free
    ]
    if problems:
        raise SpecError("\n".join(f"space: {p}" for p in problems))


def check_design(space: Space, spec: Any, model: Any) -> None:
    """Check a design study (space and spec) against the FMU (a ``FmuModel``).

    Raises
    ------
    SpecError
        Naming the field: unknown variables, free or fixed parameters the FMU lacks, or
        variables whose type does not fit their role.

    """
    check_space(
        space, list(model.inputs), list(model.outputs), model.parameters, list(spec.parameters)
    )
    problems = [
        f"spec: {field}: {name!r} is not an FMU parameter"
        for field, names in (("parameters", spec.parameters), ("fixed", spec.fixed))
        for name in names
        if name not in model.parameters
    ]
    problems += model.usage_problems(
        list(spec.parameters), spec.fixed, [space.input], list(space.outputs)
    )
    problems += [
        f"spec: per_experiment: {name!r} takes one value per experiment, which a design does "
        "not support; move it to fixed (the state a designed test starts from)"
        for name in spec.per_experiment
    ]
    if problems:
        raise SpecError("\n".join(problems))
