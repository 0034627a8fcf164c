"""Catalogue of left-out physics: the effects (:mod:`.effects`) that apply to a study.

Physics the FMU declares (or the spec lists) comes first; then the patterns that wrap any FMU.
Ranges come from the data and the FMU, never from one model:

=====================  ==========================  ===========================================
effect                 parameter                   range
=====================  ==========================  ===========================================
input_offset           offset_<input>              +-half the input's largest magnitude
input_gain             gain_<input>                0.5 to 2 (off at 1)
input_dead_zone        dead_<input>                0 to the 60 % quantile of the input's size
input_saturation       limit_<input>               its 50 % quantile to its largest size (off)
input_lag, delay       tau_<input>, delay_<input>  a 1000th of the median sample interval to
                                                   a fifth of the record (log scale, off at 0)
output_lag             tau_outputs, tau_<output>   as the input lag
output_gain, bias      gain_<output>, bias_<...>   0.5 to 2; +-half the output's magnitude
output_saturation      max_<output>, min_<output>  from the median to past the data's extreme
feedback_polynomial    c<k>_<output>_<input>       k = 2, 3: +-4 u / y^k (u, y: magnitudes)
feedback_friction      coulomb_<rate>_<input>      +-4 u; smooth sign over 2 % of the rate
=====================  ==========================  ===========================================

Threshold effects (dead zone, saturations) have no sensitivity at their off level: their screen
probes levels inside the range the signals reach (quantiles of the data), not the off level.
Feedback goes into every real input of a co-simulation FMU, driven by the data or not (an
undriven input is where an FMU lets a force act from outside; its size, which the data cannot
give, is the constant whose effect on the outputs matches the base fit's misfit); its rate is an
output whose unit is the level's per second, else the finite difference of the level.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np

from fmuid.data import ParameterSpec
from fmuid.discrepancy import effects as fx
from fmuid.discrepancy.knowledge import AddedParameter, ModelKnowledge, model_knowledge
from fmuid.engine.count import counted
from fmuid.estimation.predictor import FmuPredictor
from fmuid.estimation.problem import Problem
from fmuid.model.registry import get_simulator

POWERS = (2, 3)
"""Powers of the polynomial feedback candidates (the linear term is the model's own)."""

FRICTION_WIDTH = 0.02
"""Width of the smooth sign of a friction term, as a share of the rate's largest magnitude."""

SPREAD = (0.003, 0.02, 0.1, 0.4, 1.0)
"""Shares of its bound at which a nonlinear term's coefficient is screened (each sign)."""

TIME_FLOOR = 1e-3
"""Smallest lag or delay, as a share of the median sample interval (off is 0; its screen probes
here, where the effect is linear in the time constant)."""

LEVELS = (0.5, 0.7, 0.8, 0.9, 0.95, 0.98)
"""Quantiles of a signal's size at which a threshold effect is screened; past the last, levels
go on towards the extreme, each clipping 2.5 times fewer samples, down to two (:func:`levels`)."""


@dataclass(frozen=True)
class Signals:
    """What the data say about the sizes of a study's signals.

    Attributes
    ----------
    inputs, outputs
        Samples of each driven input and fitted output, all experiments together.
    rates
        Largest magnitude of each rate a friction term may use, by source name.
    interval, record
        Median sample interval and longest record [s].
    undriven
        Size of each FMU input the data do not drive: the constant value whose effect on the
        outputs matches the base fit's misfit (:func:`undriven_sizes`).

    """

    inputs: Mapping[str, np.ndarray]
    outputs: Mapping[str, np.ndarray]
    rates: Mapping[str, float]
    interval: float
    record: float
    undriven: Mapping[str, float]

    def size(self, name: str) -> float:
        """Return the largest magnitude of a signal in the data (an undriven input's size)."""
        if name in self.undriven:
            return self.undriven[name]
        values = self.inputs.get(name, self.outputs.get(name))
        if values is None or not values.size:
            return 1.0
        return max(float(np.max(np.abs(values))), 1e-12)


def _spec(start: float, lower: float, upper: float, scale: Literal["log", "lin"]) -> ParameterSpec:
    return ParameterSpec(start=start, lower=lower, upper=upper, scale=scale)


def _time_constant(name: str, meaning: str, s: Signals) -> AddedParameter:
    lower = s.interval * TIME_FLOOR
    upper = max(s.record / 5, 10 * lower)
    decades = np.log10(upper / lower)
    points = min(int(2 * decades) + 2, 10)
    grid = tuple(np.logspace(np.log10(lower), np.log10(upper), points).tolist())
    start = float(np.sqrt(lower * upper))
    return AddedParameter(
        name, "s", meaning, _spec(start, lower, upper, "log"), 0.0, "low", probe=lower, grid=grid
    )


def _signed(name: str, unit: str, meaning: str, bound: float) -> AddedParameter:
    return AddedParameter(name, unit, meaning, _spec(0.0, -bound, bound, "lin"), 0.0, "inside")


def _nonlinear(name: str, unit: str, meaning: str, bound: float) -> AddedParameter:
    """Return a signed coefficient of a nonlinear term, probed at 1 % of its bound.

    Its screen tries a grid spread over three decades on both sides (its effect is far from
    linear in the coefficient).
    """
    steps = [f * bound for f in SPREAD]
    grid = tuple(sorted([*steps, *(-v for v in steps)]))
    return AddedParameter(
        name,
        unit,
        meaning,
        _spec(0.0, -bound, bound, "lin"),
        0.0,
        "inside",
        probe=0.01 * bound,
        grid=grid,
    )


def _gain(name: str, meaning: str) -> AddedParameter:
    return AddedParameter(name, "1", meaning, _spec(1.0, 0.5, 2.0, "lin"), 1.0, "inside")


def levels(n: int) -> tuple[float, ...]:
    """Return the quantile levels of a threshold screen on ``n`` samples (see :data:`LEVELS`).

    A threshold that the base fit hides clips only the signal's extremes: a few samples of a long
    record, far past the 98 % quantile.
    """
    out, share = list(LEVELS), 1.0 - LEVELS[-1]
    while (share := share / 2.5) * n >= 2:
        out.append(1.0 - share)
    return tuple(out)


def _quantiles(values: np.ndarray, levels: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(float(q) for q in np.quantile(values, levels))


def _input_effects(name: str, unit: str, s: Signals, w: fx.Words) -> list[fx.Effect]:
    size = np.abs(s.inputs[name])
    top = s.size(name)
    what = f"input {name}"
    out: list[fx.Effect] = [
        fx.InputOffset(name, (_signed(f"offset_{name}", unit, f"offset on {what}", top / 2),), w),
        fx.InputGain(name, (_gain(f"gain_{name}", f"gain on {what}"),), w),
        fx.InputLag(name, (_time_constant(f"tau_{name}", f"first-order lag of {what}", s),), w),
        fx.InputDelay(name, (_time_constant(f"delay_{name}", f"dead time on {what}", s),), w),
    ]
    dead = _quantiles(size, (0.05, 0.1, 0.2, 0.3, 0.45, 0.6))
    if dead[-1] > 0:
        p = AddedParameter(
            f"dead_{name}",
            unit,
            f"dead zone of {what}",
            _spec(0.0, 0.0, dead[-1], "lin"),
            0.0,
            "low",
            probe=dead[2],
            grid=dead,
        )
        out.append(fx.InputDeadZone(name, (p,), w))
    limits = _quantiles(size, levels(size.size))
    if limits[0] < top:
        p = AddedParameter(
            f"limit_{name}",
            unit,
            f"saturation of {what}",
            _spec(top, limits[0], top, "lin"),
            top,
            "high",
            probe=limits[len(LEVELS) - 2],
            grid=limits,
        )
        out.append(fx.InputSaturation(name, (p,), w))
    return out


def _output_effects(name: str, unit: str, s: Signals, w: fx.Words) -> list[fx.Effect]:
    y = s.outputs[name]
    top = s.size(name)
    what = f"output {name}"
    out: list[fx.Effect] = [
        fx.OutputGain(name, (_gain(f"gain_{name}", f"gain on {what}"),), w),
        fx.OutputBias(name, (_signed(f"bias_{name}", unit, f"bias on {what}", top / 2),), w),
    ]
    span = float(np.max(y) - np.min(y)) if y.size else 0.0
    if span > 0:
        high = _quantiles(y, levels(y.size))
        upper = float(np.max(y)) + span / 4
        p = AddedParameter(
            f"max_{name}",
            unit,
            f"upper limit of {what}",
            _spec(upper, high[0], upper, "lin"),
            upper,
            "high",
            probe=high[len(LEVELS) - 2],
            grid=(*high, float(np.max(y))),
        )
        out.append(fx.OutputSaturation(name, (p,), w, upper=True))
        low = _quantiles(y, tuple(1 - q for q in levels(y.size)))
        lower = float(np.min(y)) - span / 4
        p = AddedParameter(
            f"min_{name}",
            unit,
            f"lower limit of {what}",
            _spec(lower, lower, low[0], "lin"),
            lower,
            "low",
            probe=low[len(LEVELS) - 2],
            grid=(*low, float(np.min(y))),
        )
        out.append(fx.OutputSaturation(name, (p,), w, upper=False))
    return out


def _feedback_effects(
    problem: Problem, s: Signals, w: fx.Words, rate_of: Mapping[str, tuple[str, bool]]
) -> list[fx.Effect]:
    targets = [
        n
        for n, v in problem.model.inputs.items()
        if v.is_continuous and (n in problem.inputs or n in s.undriven)
    ]
    out: list[fx.Effect] = []
    for u in targets:
        u_size = s.size(u)
        for y in problem.outputs:
            y_size = s.size(y)
            for k in POWERS:
                name, unit = f"c{k}_{y}_{u}", w.per_power(u, y, k)
                p = _nonlinear(name, unit, f"{y}^{k} fed into {u}", 4 * u_size / y_size**k)
                out.append(fx.FeedbackPolynomial(u, (p,), w, source=y, power=k))
        for source, (rate, derivative) in rate_of.items():
            width = FRICTION_WIDTH * s.rates.get(source, 1.0)
            p = _nonlinear(f"coulomb_{rate}_{u}", w.unit(u), f"Coulomb friction on {u}", 4 * u_size)
            out.append(
                fx.FeedbackFriction(u, (p,), w, source=source, derivative=derivative, width=width)
            )
    return out


def rate_sources(problem: Problem, units: Mapping[str, str]) -> dict[str, tuple[str, bool]]:
    """Rates a friction term can use: ``{source: (rate name, by finite difference)}``.

    An FMU output whose unit is a fitted output's unit per second is that output's rate; a
    fitted output whose unit is already per second is a rate itself; otherwise the finite
    difference of the fitted output is its rate (named ``d<output>``), when the output is a
    position (its unit a length or an angle) or declares no unit: friction acts against a
    motion, not against the rate of a voltage or a force.
    """
    words = fx.Words(units)
    out: dict[str, tuple[str, bool]] = {}
    for y in problem.outputs:
        unit = units.get(y, "")
        if unit.endswith("/s"):
            out[y] = (y, False)
            continue
        match = [o for o in problem.model.outputs if unit and units.get(o) == f"{unit}/s"]
        if match:
            out[match[0]] = (match[0], False)
        elif not unit or words.quantity(y) in ("displacement", "angle"):
            out[y] = (f"d{y}", True)
    return out


def signals(
    problem: Problem, rates: Mapping[str, tuple[str, bool]], values: Mapping[str, float]
) -> Signals:
    """Sizes of the study's signals, and of the rates (an unfitted one simulated at ``values``)."""
    inputs = {
        name: np.concatenate([exp.input_samples(name)[1] for exp in problem.experiments])
        for name in problem.inputs
    }
    outputs = {
        o: np.concatenate([d[j] for d in problem.data]) for j, o in enumerate(problem.outputs)
    }
    gaps = np.concatenate([np.diff(exp.time) for exp in problem.experiments])
    record = max(float(exp.time[-1] - exp.time[0]) for exp in problem.experiments)
    sizes: dict[str, float] = {}
    for source, (_, derivative) in rates.items():
        if source in outputs and not derivative:
            sizes[source] = float(np.max(np.abs(outputs[source])))
            continue
        if derivative:
            j = problem.outputs.index(source)
            per = [
                np.diff(d[j]) / np.diff(e.time[ms[j]])
                for e, d, ms in zip(problem.experiments, problem.data, problem.masks)
                if ms[j].sum() > 2
            ]
            sizes[source] = float(np.quantile(np.abs(np.concatenate(per)), 0.95)) if per else 1.0
            continue
        exp = problem.experiments[0]
        y = problem.simulate(values, exp, [source])
        sizes[source] = float(np.max(np.abs(y)))
    interval = float(np.median(gaps[gaps > 0])) if np.any(gaps > 0) else 1.0
    rate_sizes = {k: max(v, 1e-12) for k, v in sizes.items()}
    undriven = undriven_sizes(problem, values)
    return Signals(inputs, outputs, rate_sizes, interval, record, undriven)


def undriven_sizes(problem: Problem, values: Mapping[str, float]) -> dict[str, float]:
    """Return the size of each real FMU input the data do not drive, from the FMU's response.

    The data say nothing of such an input's scale, so the first experiment is simulated with the
    input held at 1 (its unit): the size is the base fit's RMS misfit over the RMS change of the
    outputs, the largest over the outputs (the constant that would move the outputs as much as
    the misfit does). An input that moves no output is left out (nothing can act through it).
    """
    undriven = [
        n for n, v in problem.model.inputs.items() if v.is_continuous and n not in problem.inputs
    ]
    predictor = getattr(problem.predictor, "base", problem.predictor)
    if not undriven or not isinstance(predictor, FmuPredictor):
        return {}
    exp, mask, data = problem.experiments[0], problem.masks[0], problem.data[0]
    base = problem.predictor.predict(values, exp, problem.outputs)
    input_time, inputs = predictor.inputs_of(exp)
    params = predictor.fmu_values(values, exp)
    out = {}
    for name in undriven:
        pushed = get_simulator(problem.model).simulate(
            params,
            input_time,
            {**inputs, name: np.ones(len(input_time))},
            exp.time,
            problem.outputs,
        )
        counted(2)
        ratios = []
        for j in range(len(problem.outputs)):
            if mask[j].sum() < 2:
                continue
            misfit = float(np.sqrt(np.mean((data[j] - base[mask[j], j]) ** 2)))
            moved = float(np.sqrt(np.mean((pushed[mask[j], j] - base[mask[j], j]) ** 2)))
            if moved > 0 and np.isfinite(moved):
                ratios.append(misfit / moved)
        if ratios and max(ratios) > 0:
            out[name] = max(ratios)
    return out


def catalogue(
    problem: Problem, knowledge: ModelKnowledge, values: Mapping[str, float]
) -> list[fx.Effect]:
    """Return every effect that applies to a study (declared physics first).

    ``values`` are the base model's parameters (its fit). Effects whose parameters the spec
    already fits or fixes are left out.
    """
    variables = {**problem.model.inputs, **problem.model.outputs}
    units = {name: v.unit or "" for name, v in variables.items()}
    words = fx.Words(units, dict(knowledge.roles))
    rates = rate_sources(problem, units)
    s = signals(problem, rates, values)
    out: list[fx.Effect] = [
        fx.DeclaredPhysics("", p.parameters, declared=p.effect, description=p.description)
        for p in knowledge.physics
    ]
    for name in problem.inputs:
        if problem.model.inputs[name].is_continuous:
            out.extend(_input_effects(name, units[name], s, words))
    lag = _time_constant("tau_outputs", "time constant of a first-order lag on the outputs", s)
    out.append(fx.OutputLag("", (lag,), words))
    for name in problem.outputs:
        if len(problem.outputs) > 1:
            tau = _time_constant(f"tau_{name}", f"first-order lag of output {name}", s)
            out.append(fx.OutputLag(name, (tau,), words))
        out.extend(_output_effects(name, units.get(name, ""), s, words))
    if problem.model.is_cosimulation:
        out.extend(_feedback_effects(problem, s, words, rates))
    taken = set(problem.spec.parameters) | set(problem.spec.fixed)
    return [e for e in out if not set(e.names) & taken]


def study_catalogue(problem: Problem, values: Mapping[str, float]) -> list[fx.Effect]:
    """Return the catalogue of an estimation problem at its fitted ``values``."""
    return catalogue(problem, model_knowledge(problem.model, problem.spec), values)
