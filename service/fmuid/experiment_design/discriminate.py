"""Model discrimination: the feasible test that best tells two fitted hypotheses apart.

For a test, hypothesis B is fitted to A's noise-free prediction and A to B's; the smaller of the
two weighted misfits (chi2 at the space's noise) is the expected separation: data made by either
hypothesis then give a likelihood-ratio statistic ``chi2_wrong - chi2_right`` of about that size
(non-central chi-square with that non-centrality). The screen uses the Gauss-Newton (linearised)
misfit, the best few tests are confirmed with full fits.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import chi2 as chi2_dist

from fmuid.data import ParameterSpec, Spec
from fmuid.estimation.optimize import fit_problem, jacobian
from fmuid.estimation.predictor import FmuPredictor
from fmuid.estimation.problem import Problem
from fmuid.estimation.wrappers import AugmentedPredictor
from fmuid.experiment_design.fisher import trial_spec
from fmuid.experiment_design.signals import (
    Trial,
    output_times,
    sample_trials,
    trial_experiment,
    trial_from_dict,
)
from fmuid.experiment_design.space import Space, space_from_json
from fmuid.model.builtin import resolve_fmu
from fmuid.model.fmu import FmuModel
from fmuid.progress import Progress, ProgressCallback

CONFIRM = 3
"""Best screened tests confirmed with full fits."""


@dataclass(frozen=True)
class Hypothesis:
    """One explanation of the data: an FMU, its free parameters and the values it predicts with.

    Attributes
    ----------
    name
        Label, e.g. ``"sensor_lag"``.
    parameters
        Free parameters of this hypothesis (the study's plus any added ones).
    values
        Parameter values under which it predicts (e.g. its fit to the data).
    wrappers
        Generic effects around the FMU, as :class:`fmuid.estimation.wrappers.AugmentedPredictor`
        takes them: ``{parameter: (kind, input or output)}``, e.g.
        ``{"tau_sensor": ("sensor_lag", None)}``.
    fixed
        FMU parameter values of this hypothesis (switchable physics).
    fmu
        Another FMU for this hypothesis (default: the study's).

    """

    name: str
    parameters: Mapping[str, ParameterSpec]
    values: Mapping[str, float]
    wrappers: Mapping[str, tuple[str, str | None]] = field(default_factory=dict)
    fixed: Mapping[str, float] = field(default_factory=dict)
    fmu: str | Path | None = None

    def problem(
        self,
        fmu: Path,
        spec: Spec,
        space: Space,
        trial: Trial,
        values: Mapping[str, np.ndarray] | None = None,
    ) -> Problem:
        """Return the estimation problem of this hypothesis on a trial's (simulated) data."""
        path = Path(resolve_fmu(self.fmu)) if self.fmu is not None else fmu
        tspec = trial_spec(spec, space, trial).model_copy(
            update={
                "parameters": dict(self.parameters),
                "fixed": {**spec.fixed, **trial.fixed, **self.fixed},
            }
        )
        model = _model(path)
        base = FmuPredictor(model, tspec.fixed, [space.input])
        predictor = AugmentedPredictor(base, dict(self.wrappers)) if self.wrappers else base
        exp = trial_experiment(trial, space.input, values)
        return Problem(path, [exp], tspec, predictor=predictor, model=model)


@functools.lru_cache(maxsize=8)
def _model(path: Path) -> FmuModel:
    return FmuModel(path)


@dataclass(frozen=True)
class Discrimination:
    """The proposed test and its expected separation.

    Attributes
    ----------
    trial
        The test.
    hypotheses
        Names of A and B.
    separation
        ``{"B fitted to A": chi2, "A fitted to B": chi2}`` on noise-free data.
    time, predictions
        Sensor times [s] and each hypothesis's noise-free outputs there (for the plot).
    input_name
        The FMU input driven.
    screened
        Tests scored.
    sigma
        Noise standard deviation of each sensor of the test (the space's), in the output's unit.
    confirmed
        Whether ``separation`` comes from full fits (else from the linearised screen).

    """

    trial: Trial
    hypotheses: tuple[str, str]
    separation: dict[str, float]
    time: np.ndarray
    predictions: dict[str, dict[str, np.ndarray]]
    input_name: str
    screened: int
    sigma: dict[str, float] = field(default_factory=dict)
    confirmed: bool = True

    @property
    def expected_chi2(self) -> float:
        """The smaller separation: the expected likelihood-ratio statistic."""
        return min(self.separation.values())

    def to_dict(self) -> dict[str, Any]:
        """JSON form (``discriminating_experiment`` of the diagnose result).

        ``time`` and ``predictions`` (6 significant digits) carry what the plot draws.
        """
        lam = self.expected_chi2
        return {
            "experiment": self.trial.to_dict(self.input_name),
            "hypotheses": list(self.hypotheses),
            "expected_separation": {k: round(v, 4) for k, v in self.separation.items()},
            "expected_chi2": round(lam, 4),
            "expected_p_value": float(chi2_dist.sf(lam, 1)),
            "screened": self.screened,
            "noise_sigma": dict(self.sigma),
            "confirmed": self.confirmed,
            "time": _digits(self.time),
            "predictions": {
                h: {o: _digits(y) for o, y in ys.items()} for h, ys in self.predictions.items()
            },
        }


def _digits(values: np.ndarray) -> list[float]:
    return [float(f"{v:.6g}") for v in np.asarray(values, dtype=float)]


def discrimination_from_dict(doc: Mapping[str, Any]) -> Discrimination:
    """Rebuild a :class:`Discrimination` from its :meth:`Discrimination.to_dict` form."""
    experiment = doc["experiment"]
    a, b = doc["hypotheses"]
    return Discrimination(
        trial=trial_from_dict(experiment),
        hypotheses=(str(a), str(b)),
        separation={str(k): float(v) for k, v in doc["expected_separation"].items()},
        time=np.asarray(doc["time"], dtype=float),
        predictions={
            str(h): {str(o): np.asarray(y, dtype=float) for o, y in ys.items()}
            for h, ys in doc["predictions"].items()
        },
        input_name=str(experiment["input_variable"]),
        screened=int(doc["screened"]),
        sigma={str(o): float(v) for o, v in (doc.get("noise_sigma") or {}).items()},
        confirmed=bool(doc.get("confirmed", True)),
    )


def _clean(problem: Problem, values: Mapping[str, float]) -> dict[str, np.ndarray]:
    y = problem.predict(values)[0]
    mask = problem.masks[0][0]
    return {o: y[o][mask] for o in problem.outputs}


def _linear_misfit(fitted: Problem, start: Mapping[str, float]) -> float:
    """Gauss-Newton misfit: the residual's part outside the span of the sensitivities."""
    z = fitted.to_z(start)
    r = fitted.residuals(z)
    jac = jacobian(fitted, z)
    step, *_ = np.linalg.lstsq(jac, r, rcond=None)
    rest = r - jac @ step
    return float(rest @ rest)


def _separation(
    fmu: Path, spec: Spec, space: Space, trial: Trial, a: Hypothesis, b: Hypothesis, full: bool
) -> tuple[dict[str, float], dict[str, dict[str, np.ndarray]]]:
    ya = _clean(a.problem(fmu, spec, space, trial), a.values)
    yb = _clean(b.problem(fmu, spec, space, trial), b.values)
    sep = {}
    for fitted, data, name in (
        (b, ya, f"{b.name} fitted to {a.name}"),
        (a, yb, f"{a.name} fitted to {b.name}"),
    ):
        problem = fitted.problem(fmu, spec, space, trial, data)
        if full:
            sep[name] = fit_problem(problem, start=fitted.values, global_search=False).chi2
        else:
            sep[name] = _linear_misfit(problem, fitted.values)
    return sep, {a.name: ya, b.name: yb}


def discriminating_experiment(
    fmu: str | Path,
    spec: Spec,
    space: Space,
    a: Hypothesis,
    b: Hypothesis,
    *,
    progress: ProgressCallback | None = None,
    confirm_from: float = 0.0,
) -> Discrimination:
    """Propose the feasible test that maximises the expected chi2 separation of A and B.

    Parameters
    ----------
    fmu
        The study's FMU (file or built-in name).
    spec
        The study (fixed parameters, confidence); free parameters come from the hypotheses.
    space
        The feasible tests and the noise per sensor (:func:`default_space` builds one from
        the data of a study).
    a, b
        The two hypotheses.
    progress
        Receives ``Progress("discriminate", done, total, detail)``.
    confirm_from
        The best screened tests are confirmed by full fits only when the largest linearised
        separation reaches this; below it the best screened test is returned with its
        linearised separation (``confirmed`` false), e.g. when a caller only needs to know
        whether any test reaches a significance level far above it.

    Returns
    -------
    Discrimination

    """
    path = Path(resolve_fmu(fmu))
    trials = [
        t.with_(outputs=s)
        for t in sample_trials(space, np.random.default_rng(space.seed))
        for s in space.sensor_sets()
    ]
    scored = []
    for k, trial in enumerate(trials):
        sep, _ = _separation(path, spec, space, trial, a, b, full=False)
        scored.append((min(sep.values()), k))
        if progress:
            progress(Progress("discriminate", k + 1, len(trials), "linearised screen"))
    scored.sort(reverse=True)
    if scored[0][0] < confirm_from:
        trial = trials[scored[0][1]]
        sep, pred = _separation(path, spec, space, trial, a, b, full=False)
        confirmed = False
    else:
        best: tuple[float, Trial, dict[str, float], dict[str, dict[str, np.ndarray]]] | None = None
        for _, k in scored[:CONFIRM]:
            sep, pred = _separation(path, spec, space, trials[k], a, b, full=True)
            if best is None or min(sep.values()) > best[0]:
                best = (min(sep.values()), trials[k], sep, pred)
        assert best is not None
        _, trial, sep, pred = best
        confirmed = True
    sigma = {o: space.outputs[o].sigma for o in trial.outputs}
    return Discrimination(
        trial, (a.name, b.name), sep, output_times(trial), pred, space.input, len(trials), sigma,
        confirmed,
    )  # fmt: skip


def default_space(problem: Problem) -> Space:
    """Return a space like the study's data: input, amplitude, longest test, rate, noise.

    Step, chirp (0.05 Hz to the sensors' Nyquist / 4) and multisine tests up to the largest
    absolute input of the data, as long as the longest experiment, at the data's median rate,
    measuring the study's outputs with their resolved sigma.
    """
    name = problem.inputs[0]
    amp = max(float(np.max(np.abs(e.input_samples(name)[1]))) for e in problem.experiments) or 1.0
    longest = max(float(e.time[-1] - e.time[0]) for e in problem.experiments)
    steps = np.concatenate(
        [np.diff(e.time[m]) for e, ms in zip(problem.experiments, problem.masks) for m in ms]
    )
    rate = float(f"{1.0 / float(np.median(steps)):.6g}")
    f_top = max(rate / 8.0, 0.1)
    sigma = problem.representative_sigma()
    doc = {
        "input": name,
        "families": {
            "step": {"amplitude": [-amp, amp], "time": [0.1 * longest, 0.5 * longest]},
            "chirp": {
                "f0": [0.05, f_top / 2],
                "f1": [f_top / 2, f_top],
                "amplitude": [0.5 * amp, amp],
            },
            "multisine": {
                "f_min": [0.05, f_top / 4],
                "f_max": [f_top / 2, f_top],
                "amplitude": [0.5 * amp, amp],
                "tones": [2, 6],
            },
        },
        "duration": [longest, longest],
        "rates_hz": [rate],
        "outputs": {o: {"sigma": s} for o, s in sigma.items() if math.isfinite(s)},
        "longest_test": longest,
        "candidates": 8,
        "seed": problem.spec.seed,
    }
    import json

    return space_from_json(json.dumps(doc), "default space of the study")
