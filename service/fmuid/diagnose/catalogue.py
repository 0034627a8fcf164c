"""Catalogue of left-out physics: candidates that each add one or two parameters to a model.

Generic candidates wrap any FMU (they act on its inputs or outputs); physics candidates switch
on FMU parameters that are off by default (the built-in tractor's ``alpha_sat`` and ``slope``,
or what a spec declares under ``physics``). Names and units follow the contract's table.

=================  ====================  =================================================
effect             parameter             acts as
=================  ====================  =================================================
sensor_lag         tau_sensor [s]        measured outputs = first-order lag of the model's
input_delay        delay_<input> [s]     the FMU sees the input ``delay`` seconds late
steering_lag       tau_steer [s]         the FMU sees the input through a first-order lag
steer_offset       offset_steer [rad]    the FMU sees input + offset
gyro_bias          bias_<output>         measured output = model output + bias
tire_saturation    alpha_sat [rad]       F = -C alpha_sat tanh(alpha / alpha_sat) in the FMU
side_slope         slope [rad]           gravity on a side slope, in the FMU
=================  ====================  =================================================

For an input other than the tractor's ``delta``, ``steering_lag`` and ``steer_offset`` name
their parameter ``tau_<input>`` and ``offset_<input>``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter

from fmuid.data import Experiment, ParameterSpec, Spec
from fmuid.fit.predictor import FmuPredictor
from fmuid.model.simulator import get_simulator

TRACTOR = "tractor_implement"
"""Model name of the built-in tractor FMU, whose switchable physics is known without a spec."""

STEER_INPUT = "delta"
"""The tractor's steer input; its offset and lag parameters carry the contract's names."""

INPUT_STEP = 0.02
"""Grid step [s] of a lagged input handed to the FMU (at most half the data's interval)."""

FILTER_STEP = 0.005
"""Grid step [s] on which a sensor lag filters the outputs, interpolated there by a cubic
spline through the FMU's own step times (no extra FMU steps)."""


@dataclass(frozen=True)
class AddedParameter:
    """A parameter a candidate adds.

    Attributes
    ----------
    name, unit, meaning
        As reported.
    spec
        Start, bounds and scale for the fit.
    off
        The value at which the effect vanishes.
    off_side
        Where ``off`` lies for the "CI excludes off" check: ``"inside"`` the bounds,
        ``"low"`` (below the lower bound, e.g. a time constant of 0 on a log scale) or
        ``"high"`` (beyond the upper bound, e.g. ``alpha_sat`` whose off value 0 means
        infinitely large).

    """

    name: str
    unit: str
    meaning: str
    spec: ParameterSpec
    off: float
    off_side: str = "inside"


@dataclass(frozen=True)
class Candidate:
    """One candidate of left-out physics.

    Attributes
    ----------
    effect
        Catalogue name (or the spec's physics key).
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


def catalogue(
    model_name: str,
    model_parameters: Sequence[str],
    spec: Spec,
    inputs: Sequence[str],
    outputs: Sequence[str],
    output_scale: Mapping[str, float],
) -> list[Candidate]:
    """Return every candidate that applies to a study.

    Parameters
    ----------
    model_name
        The FMU's model name (the tractor's physics is known for ``tractor_implement``).
    model_parameters
        Names of the FMU's parameters.
    spec
        The study; candidates whose parameters are already free or fixed are left out.
    inputs, outputs
        The FMU inputs driven and the outputs fitted.
    output_scale
        Largest absolute data value per output, to bound the biases.

    """
    taken = set(spec.parameters) | set(spec.fixed)
    out: list[Candidate] = [
        Candidate(
            "sensor_lag",
            (_time_constant("tau_sensor", "time constant of a first-order lag on the outputs"),),
            ("sensor_lag", None),
            "the measured outputs lag the model by a first-order filter of time constant "
            "{value} s",
        )
    ]
    for name in inputs:
        steer = "steer" if name == STEER_INPUT else name
        out.append(
            Candidate(
                "input_delay",
                (
                    AddedParameter(
                        f"delay_{name}", "s", f"dead time on input {name}",
                        ParameterSpec(start=0.05, lower=0.005, upper=1.0, scale="log"), 0.0, "low",
                    ),
                ),  # fmt: skip
                ("input_delay", name),
                f"the model sees input {name} about {{value}} s late (dead time)",
            )
        )
        out.append(
            Candidate(
                "steering_lag",
                (_time_constant(f"tau_{steer}", f"first-order lag of input {name}"),),
                ("steering_lag", name),
                f"input {name} acts through a first-order actuator lag of time constant "
                "{value} s",
            )
        )
        out.append(
            Candidate(
                "steer_offset",
                (
                    AddedParameter(
                        f"offset_{steer}", "rad" if name == STEER_INPUT else "",
                        f"offset on {name}",
                        ParameterSpec(start=0.0, lower=-0.05, upper=0.05, scale="lin"), 0.0,
                    ),
                ),  # fmt: skip
                ("steer_offset", name),
                f"input {name} carries a constant offset of {{value}}",
            )
        )
    for name in outputs:
        bound = max(0.25 * float(output_scale.get(name, 1.0)), 1e-12)
        out.append(
            Candidate(
                "gyro_bias",
                (
                    AddedParameter(
                        f"bias_{name}", "", f"constant bias on output {name}",
                        ParameterSpec(start=0.0, lower=-bound, upper=bound, scale="lin"), 0.0,
                    ),
                ),  # fmt: skip
                ("gyro_bias", name),
                f"output {name} is recorded with a constant bias of {{value}}",
            )
        )
    out.extend(physics_candidates(model_name, model_parameters, spec))
    return [c for c in out if not set(c.names) & taken]


def physics_candidates(
    model_name: str, model_parameters: Sequence[str], spec: Spec
) -> list[Candidate]:
    """FMU-internal switchable physics: the tractor's own plus the spec's ``physics``."""
    out: dict[str, Candidate] = {}
    if model_name == TRACTOR:
        out["tire_saturation"] = Candidate(
            "tire_saturation",
            (
                AddedParameter(
                    "alpha_sat", "rad", "slip angle at which the lateral tire force saturates",
                    ParameterSpec(start=1.0, lower=0.005, upper=1.0, scale="log"), 0.0, "high",
                ),
            ),  # fmt: skip
            None,
            "the lateral tire forces saturate with slip angle (F = -C alpha_sat "
            "tanh(alpha/alpha_sat), alpha_sat = {value} rad)",
        )
        out["side_slope"] = Candidate(
            "side_slope",
            (
                AddedParameter(
                    "slope", "rad", "side-slope angle of the ground",
                    ParameterSpec(start=0.0, lower=-0.2, upper=0.2, scale="lin"), 0.0,
                ),
            ),  # fmt: skip
            None,
            "gravity on a side slope of {value} rad pulls both bodies sideways",
        )
    for effect, physics in spec.physics.items():
        params = []
        for name, p in physics.parameters.items():
            side = "low" if p.off < p.lower else "high" if p.off > p.upper else "inside"
            bounds = ParameterSpec(start=p.start, lower=p.lower, upper=p.upper, scale=p.scale)
            params.append(AddedParameter(name, p.unit, p.description, bounds, p.off, side))
        text = physics.description or f"the switchable physics '{effect}' is on"
        out[effect] = Candidate(effect, tuple(params), None, text + " ({value})")
    known = set(model_parameters)
    return [c for c in out.values() if set(c.names) <= known]


def first_order_lag(time: np.ndarray, values: np.ndarray, tau: float) -> np.ndarray:
    """Exact first-order lag ``y' = (u - y) / tau`` of a piecewise-linear ``u``, from rest at u[0].

    Parameters
    ----------
    time
        Sample times [s], increasing.
    values
        Samples of ``u`` (first axis along time); ``u`` is linear between them.
    tau
        Time constant [s], > 0.

    """
    h = np.diff(time)
    u = np.asarray(values, dtype=float)
    if len(h) and np.allclose(h, h[0], rtol=1e-6):
        a = float(np.exp(-h[0] / tau))
        b0 = 1.0 - tau / h[0] * (1.0 - a)
        return u[0] + lfilter([b0, 1.0 - a - b0], [1.0, -a], u - u[0], axis=0)
    a_k = np.exp(-h / tau)
    ramp = 1.0 - tau / h * (1.0 - a_k)
    y = np.empty_like(u)
    y[0] = u[0]
    for k in range(len(h)):
        y[k + 1] = a_k[k] * y[k] + (1.0 - a_k[k]) * u[k] + ramp[k] * (u[k + 1] - u[k])
    return y


@dataclass
class AugmentedPredictor:
    """An FMU predictor wrapped by generic candidates (any number, applied together).

    Input effects apply in the order offset, lag, delay; output effects in the order lag, bias.
    Parameters of the wrappers are removed before the rest go to the FMU.

    Parameters
    ----------
    base
        The FMU predictor of the study (fixed values, inputs).
    wrappers
        ``{parameter name: (kind, input or output)}`` of the generic candidates switched on.

    """

    base: FmuPredictor
    wrappers: dict[str, tuple[str, str | None]]
    _grids: dict[tuple[int, float], tuple[Experiment, np.ndarray, np.ndarray]] = field(
        default_factory=dict
    )

    def __getstate__(self) -> dict[str, object]:
        """Pickle without the per-process grid cache."""
        return {"base": self.base, "wrappers": self.wrappers, "_grids": {}}

    def _fine(self, experiment: Experiment, step: float) -> tuple[np.ndarray, np.ndarray]:
        """Time grid of about ``step`` holding every data row, and the rows' indices in it."""
        key = (id(experiment), step)
        cached = self._grids.get(key)
        if cached is None or cached[0] is not experiment:
            t = experiment.time
            step = min(step, float(np.min(np.diff(t))) / 2)
            fine = np.arange(t[0], t[-1], step)
            index = np.searchsorted(t, fine)
            near = np.minimum(
                np.abs(fine - t[np.clip(index, 0, len(t) - 1)]),
                np.abs(fine - t[np.clip(index - 1, 0, None)]),
            )
            grid = np.union1d(t, fine[near > 1e-3 * step])
            cached = (experiment, grid, np.searchsorted(grid, t))
            self._grids[key] = cached
        return cached[1], cached[2]

    def predict(
        self, params: Mapping[str, float], experiment: Experiment, outputs: Sequence[str]
    ) -> np.ndarray:
        """Simulate the FMU with the wrappers applied and return ``outputs`` at every row."""
        fmu_params = {k: v for k, v in params.items() if k not in self.wrappers}
        by_kind: dict[str, list[tuple[str, float]]] = {}
        for name, (kind, target) in self.wrappers.items():
            by_kind.setdefault(kind, []).append((target or "", float(params[name])))
        input_time, inputs = self.base.inputs_of(experiment)
        times = {name: input_time for name in inputs}
        values = {name: np.asarray(v, dtype=float) for name, v in inputs.items()}
        for target, offset in by_kind.get("steer_offset", []):
            values[target] = values[target] + offset
        for target, tau in by_kind.get("steering_lag", []):
            fine = np.union1d(times[target], self._fine(experiment, INPUT_STEP)[0])
            dense = np.interp(fine, times[target], values[target])
            values[target] = first_order_lag(fine, dense, tau)
            times[target] = fine
        for target, delay in by_kind.get("input_delay", []):
            t0 = times[target][0]
            times[target] = np.concatenate([[t0], times[target] + delay])
            values[target] = np.concatenate([[values[target][0]], values[target]])
        if len(inputs) > 1 or any(k in by_kind for k in ("steering_lag", "input_delay")):
            common = np.unique(np.concatenate(list(times.values())))
            values = {n: np.interp(common, times[n], v) for n, v in values.items()}
        else:
            common = next(iter(times.values()), input_time)
        lag = by_kind.get("sensor_lag", [])
        # the FMU steps over the input and output times anyway: read the outputs at all of
        # them, interpolate by a cubic spline onto the fine grid and filter there
        out_time = np.union1d(experiment.time, common[common <= experiment.time[-1]])
        out_time = out_time if lag else experiment.time
        y = get_simulator(self.base.fmu_path).simulate(
            {**self.base.fixed, **fmu_params}, common, values, out_time, list(outputs)
        )
        y = np.array(y, dtype=float)
        if lag:
            grid, rows = self._fine(experiment, FILTER_STEP)
            dense = CubicSpline(out_time, y, axis=0)(grid)
            y = first_order_lag(grid, dense, lag[0][1])[rows]
        for target, bias in by_kind.get("gyro_bias", []):
            if target in outputs:
                y[:, list(outputs).index(target)] += bias
        return y
