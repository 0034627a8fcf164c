"""Catalogue of left-out physics: candidates that each add one or more parameters to a model.

Generic candidates wrap any FMU (:mod:`fmuid.estimation.wrappers`: they act on its inputs or
outputs); physics candidates switch on FMU parameters that are off by default, as the FMU
declares them or the spec lists them (:mod:`.knowledge`). Names and units follow the
contract's table.

=================  ====================  =================================================
effect             parameter             acts as
=================  ====================  =================================================
sensor_lag         tau_sensor [s]        measured outputs = first-order lag of the model's
input_delay        delay_<input> [s]     the FMU sees the input ``delay`` seconds late
steering_lag       tau_<input> [s]       the FMU sees the input through a first-order lag
steer_offset       offset_<input>        the FMU sees input + offset
gyro_bias          bias_<output>         measured output = model output + bias
(declared)         (declared)            FMU physics switched on (e.g. ``tire_saturation``
                                         ``alpha_sat``, ``side_slope`` ``slope``)
=================  ====================  =================================================

An input whose declared role is ``steer`` gives ``tau_steer`` and ``offset_steer`` (the
contract's names for a vehicle's steer input) and descriptions that speak of steering.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from fmuid.data import ParameterSpec, Spec
from fmuid.discrepancy.knowledge import AddedParameter, ModelKnowledge, model_knowledge
from fmuid.estimation.problem import Problem


@dataclass(frozen=True)
class Candidate:
    """One candidate of left-out physics.

    Attributes
    ----------
    effect
        Catalogue name (or the declared physics' name).
    parameters
        The added parameters.
    wrapper
        For generic candidates, what the wrapper does: ``("sensor_lag", None)``,
        ``("input_delay", input)``, ``("steering_lag", input)``, ``("steer_offset", input)``,
        ``("gyro_bias", output)``; ``None`` for FMU physics.
    description
        One sentence on the effect, with ``{value}`` for the estimate.

    """

    effect: str
    parameters: tuple[AddedParameter, ...]
    wrapper: tuple[str, str | None] | None
    description: str

    @property
    def label(self) -> str:
        """Unique label: the effect and its parameter names."""
        return f"{self.effect}({', '.join(p.name for p in self.parameters)})"

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the added parameters."""
        return tuple(p.name for p in self.parameters)


def _time_constant(name: str, meaning: str) -> AddedParameter:
    spec = ParameterSpec(start=0.05, lower=0.005, upper=1.0, scale="log")
    return AddedParameter(name, "s", meaning, spec, 0.0, "low")


def _input_candidates(name: str, unit: str, steer: bool) -> list[Candidate]:
    """Delay, lag and offset of one input."""
    tag = "steer" if steer else name
    what = "the steer input" if steer else f"input {name}"
    delay = AddedParameter(
        f"delay_{name}", "s", f"dead time on {what}",
        ParameterSpec(start=0.05, lower=0.005, upper=1.0, scale="log"), 0.0, "low",
    )  # fmt: skip
    offset = AddedParameter(
        f"offset_{tag}", unit, f"constant offset on {what}",
        ParameterSpec(start=0.0, lower=-0.05, upper=0.05, scale="lin"), 0.0, "inside",
    )  # fmt: skip
    actuator = "steering actuator" if steer else "actuator"
    return [
        Candidate(
            "input_delay", (delay,), ("input_delay", name),
            f"the model sees {what} about {{value}} s late (dead time)",
        ),
        Candidate(
            "steering_lag", (_time_constant(f"tau_{tag}", f"first-order lag of {what}"),),
            ("steering_lag", name),
            f"{what} acts through a first-order {actuator} lag of time constant {{value}} s",
        ),
        Candidate(
            "steer_offset", (offset,), ("steer_offset", name),
            f"{what} carries a constant offset of {{value}} {unit}".rstrip(),
        ),
    ]  # fmt: skip


def catalogue(
    knowledge: ModelKnowledge,
    spec: Spec,
    inputs: Sequence[str],
    outputs: Sequence[str],
    output_scale: Mapping[str, float],
    units: Mapping[str, str] | None = None,
) -> list[Candidate]:
    """Return every candidate that applies to a study.

    Parameters
    ----------
    knowledge
        The model's switchable physics and variable roles.
    spec
        The study; candidates whose parameters are already free or fixed are left out.
    inputs, outputs
        The FMU inputs driven and the outputs fitted.
    output_scale
        Largest absolute data value per output, to bound the biases.
    units
        Unit per input and output, for the added parameters.

    """
    units = units or {}
    taken = set(spec.parameters) | set(spec.fixed)
    out: list[Candidate] = [
        Candidate(
            "sensor_lag",
            (_time_constant("tau_sensor", "time constant of a first-order lag on the outputs"),),
            ("sensor_lag", None),
            "the measured outputs lag the model by a first-order filter of time constant {value} s",
        )
    ]
    for name in inputs:
        out.extend(_input_candidates(name, units.get(name, ""), knowledge.role(name) == "steer"))
    for name in outputs:
        bound = max(0.25 * float(output_scale.get(name, 1.0)), 1e-12)
        unit = units.get(name, "")
        bias = AddedParameter(
            f"bias_{name}", unit, f"constant bias on output {name}",
            ParameterSpec(start=0.0, lower=-bound, upper=bound, scale="lin"), 0.0, "inside",
        )  # fmt: skip
        out.append(
            Candidate(
                "gyro_bias",
                (bias,),
                ("gyro_bias", name),
                f"output {name} is recorded with a constant bias of {{value}} {unit}".rstrip(),
            )  # fmt: skip
        )
    for physics in knowledge.physics:
        out.append(
            Candidate(
                physics.effect,
                physics.parameters,
                None,
                f"{physics.description} ({physics.parameters[0].name} = {{value}} "
                f"{physics.parameters[0].unit})".replace(" )", ")"),
            )  # fmt: skip
        )
    return [c for c in out if not set(c.names) & taken]


def study_catalogue(problem: Problem) -> list[Candidate]:
    """Return the catalogue of an estimation problem (its FMU's knowledge, spec, data, units)."""
    scale = {
        o: max(float(np.max(np.abs(np.concatenate([d[j] for d in problem.data])))), 1e-12)
        for j, o in enumerate(problem.outputs)
    }
    variables = {**problem.model.inputs, **problem.model.outputs}
    units = {name: v.unit or "" for name, v in variables.items()}
    knowledge = model_knowledge(problem.fmu_path, problem.spec)
    return catalogue(knowledge, problem.spec, problem.inputs, problem.outputs, scale, units)
