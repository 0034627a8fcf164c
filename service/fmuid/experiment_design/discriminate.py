"""Model discrimination: the feasible test that best tells two fitted hypotheses apart.

For a test, hypothesis B is fitted to A's noise-free prediction and A to B's; the smaller of the
two weighted misfits (chi2 at the space's noise) is the expected separation: data made by either
hypothesis then give a likelihood-ratio statistic ``chi2_wrong - chi2_right`` of about that size
(non-central chi-square with that non-centrality). The screen uses the Gauss-Newton (linearised)
misfit, the best few tests are confirmed with full fits.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fmuid.data import ParameterSpec, Spec
from fmuid.discrepancy.augment import AugmentedPredictor
from fmuid.discrepancy.effects import Effect
from fmuid.discrepancy.scan import serial
from fmuid.estimation.optimize import Mapper, fit_problem, jacobian
from fmuid.estimation.predictor import FmuPredictor
from fmuid.estimation.problem import Problem
from fmuid.estimation.schema import Written
from fmuid.experiment_design.fisher import trial_spec
from fmuid.experiment_design.schema import DiscriminatingOut
from fmuid.experiment_design.signals import (
    Trial,
    output_times,
    sample_trials,
    trial_experiment,
    trial_from_dict,
)
from fmuid.experiment_design.space import Space, space_from_json
from fmuid.model.builtin import resolve_fmu
from fmuid.model.fmu import model_of_file
from fmuid.progress import Progress, ProgressCallback

CONFIRM = 3
"""Best screened tests confirmed with full fits."""


@dataclass(frozen=True)
class Hypothesis:
    """One explanation of the data: an FMU, its free parameters and the values it predicts with.

    Attributes
    ----------
    name
        Label, e.g. ``"output_lag"``.
    parameters
        Free parameters of this hypothesis (the study's plus any added ones).
    values
        Parameter values under which it predicts (e.g. its fit to the data).
    effects
        Effects around the FMU (:mod:`fmuid.discrepancy.effects`), applied by
        :class:`fmuid.discrepancy.augment.AugmentedPredictor`.
    fixed
        FMU parameter values of this hypothesis (switchable physics).
    fmu
        Another FMU for this hypothesis (default: the study's).

    """

    name: str
    parameters: Mapping[str, ParameterSpec]
    values: Mapping[str, float]
    effects: tuple[Effect, ...] = ()
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
        model = model_of_file(path)
        base = FmuPredictor(model, tspec.fixed, [space.input], per_experiment=spec.per_experiment)
        predictor = AugmentedPredictor(base, self.effects) if self.effects else base
        exp = trial_experiment(trial, space.input, values)
        return Problem(path, [exp], tspec, predictor=predictor, model=model)


@dataclass(frozen=True)
class Discrimination(Written):
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

    ``to_dict`` writes :class:`~fmuid.experiment_design.schema.DiscriminatingOut` (a
    diagnosis' ``discriminating_experiment``; ``time`` and ``predictions`` to 6 digits carry
    what the plot draws).
    """

    schema = DiscriminatingOut

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


class _Screen:
    """One hypothesis on the tests of a space, each piece computed once per test.

    Its noise-free prediction and the Jacobian of its weighted residuals (which, with the noise
    given by the space, does not depend on the data) serve every other hypothesis it is
    compared with. Tests are known by their index in the list of the space's tests. The FMU
    travels as a model: a task's worker (a dask one too) finds its own copy of the file.
    """

    def __init__(self, fmu: Path, spec: Spec, space: Space, hypothesis: Hypothesis):
        self.model, self.spec, self.space = model_of_file(fmu), spec, space
        self.hypothesis = hypothesis
        self._clean: dict[int, dict[str, np.ndarray]] = {}
        self._jac: dict[int, np.ndarray] = {}

    def problem(self, trial: Trial, data: Mapping[str, np.ndarray] | None = None) -> Problem:
        return self.hypothesis.problem(self.model.path, self.spec, self.space, trial, data)

    def clean(self, k: int, trial: Trial) -> dict[str, np.ndarray]:
        """Its noise-free prediction of the samples of test ``k``."""
        if k not in self._clean:
            self._clean[k] = _clean(self.problem(trial), self.hypothesis.values)
        return self._clean[k]

    def misfit(self, k: int, trial: Trial, data: Mapping[str, np.ndarray], full: bool) -> float:
        """Its chi2 fitted to ``data``: Gauss-Newton (linearised) or by a full fit."""
        problem = self.problem(trial, data)
        if full:
            return fit_problem(problem, start=self.hypothesis.values, global_search=False).chi2
        z = problem.to_z(self.hypothesis.values)
        if k not in self._jac:
            self._jac[k] = jacobian(problem, z)
        jac = self._jac[k]
        r = problem.residuals(z)
        step, *_ = np.linalg.lstsq(jac, r, rcond=None)
        rest = r - jac @ step
        return float(rest @ rest)


def _separation(
    a: _Screen, b: _Screen, k: int, trial: Trial, full: bool
) -> tuple[dict[str, float], dict[str, dict[str, np.ndarray]]]:
    ya, yb = a.clean(k, trial), b.clean(k, trial)
    na, nb = a.hypothesis.name, b.hypothesis.name
    sep = {
        f"{nb} fitted to {na}": b.misfit(k, trial, ya, full),
        f"{na} fitted to {nb}": a.misfit(k, trial, yb, full),
    }
    return sep, {na: ya, nb: yb}


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
    found = discriminating_experiments(
        fmu, spec, space, a, [b], progress=progress, confirm_from=confirm_from
    )
    return found[0]


def discriminating_experiments(
    fmu: str | Path,
    spec: Spec,
    space: Space,
    a: Hypothesis,
    others: Sequence[Hypothesis],
    *,
    progress: ProgressCallback | None = None,
    confirm_from: float = 0.0,
    mapper: Mapper | None = None,
) -> list[Discrimination]:
    """Propose, for each of ``others``, the test that best tells it from ``a``.

    As :func:`discriminating_experiment` for each pair (A, B) of ``others``, with A's share
    of each test's screen computed once for all of them. ``mapper`` runs the screens (a task
    a test), then the confirming fits (a task a test and pair) side by side (default: in
    this process, with ``progress`` after each test).
    """
    path = Path(resolve_fmu(fmu))
    trials = [
        t.with_(outputs=s)
        for t in sample_trials(space, np.random.default_rng(space.seed))
        for s in space.sensor_sets()
    ]
    screen_a = _Screen(path, spec, space, a)
    screens = [_Screen(path, spec, space, b) for b in others]
    n = len(trials)
    if mapper is None:
        screened = []
        for k, trial in enumerate(trials):
            screened.append(_screen_test(screen_a, screens, k, trial))
            if progress:
                progress(Progress("discriminate", k + 1, n, "linearised screen"))
    else:
        screened = mapper(_screen_test, [screen_a] * n, [screens] * n, range(n), trials)
    ranked = [
        sorted(((min(screened[k][i][0].values()), k) for k in range(n)), reverse=True)
        for i in range(len(screens))
    ]
    confirm = [
        (i, k) for i, r in enumerate(ranked) if r[0][0] >= confirm_from for _, k in r[:CONFIRM]
    ]
    full = (mapper or serial)(
        _full_separation,
        [screen_a] * len(confirm),
        [screens[i] for i, _ in confirm],
        [k for _, k in confirm],
        [trials[k] for _, k in confirm],
    )
    fitted = dict(zip(confirm, full, strict=True))
    found = []
    for i, r in enumerate(ranked):
        best = max(
            (fitted[(i, k)] for _, k in r[:CONFIRM] if (i, k) in fitted),
            key=lambda f: min(f[0].values()),
            default=None,
        )
        top = r[0][1]
        (sep, pred), trial = (best[:2], best[2]) if best else (screened[top][i], trials[top])
        found.append(
            Discrimination(
                trial,
                (a.name, others[i].name),
                sep,
                output_times(trial),
                pred,
                space.input,
                n,
                {o: space.outputs[o].sigma for o in trial.outputs},
                best is not None,
            )
        )
    return found


def _screen_test(
    a: _Screen, others: Sequence[_Screen], k: int, trial: Trial
) -> list[tuple[dict[str, float], dict[str, dict[str, np.ndarray]]]]:
    """Linearised separations of A from each of ``others`` on test ``k`` (a task)."""
    return [_separation(a, b, k, trial, full=False) for b in others]


def _full_separation(
    a: _Screen, b: _Screen, k: int, trial: Trial
) -> tuple[dict[str, float], dict[str, dict[str, np.ndarray]], Trial]:
    """Separations of A and B on test ``k`` by full fits (a task)."""
    return (*_separation(a, b, k, trial, full=True), trial)


def default_space(problem: Problem) -> Space:
    """Return a space like the study's data: input, amplitude, longest test, rate, noise.

    Step, chirp (from 0.05 Hz, or from an eighth of the top frequency where that is below
    0.2 Hz, to the sensors' Nyquist / 4, at least 0.1 Hz but never above Nyquist / 2)
    and multisine tests up to the largest absolute input of the data, as long as the longest
    experiment, at the data's median rate, measuring the study's outputs with their resolved
    sigma. A process sampled every 4 s gets frequencies from 0.0078 to 0.0625 Hz.
    """
    name = problem.inputs[0]
    amp = max(float(np.max(np.abs(e.input_samples(name)[1]))) for e in problem.experiments) or 1.0
    longest = max(float(e.time[-1] - e.time[0]) for e in problem.experiments)
    steps = np.concatenate(
        [np.diff(e.time[m]) for e, ms in zip(problem.experiments, problem.masks) for m in ms]
    )
    rate = float(f"{1.0 / float(np.median(steps)):.6g}")
    f_top = min(max(rate / 8.0, 0.1), rate / 4.0)
    f_low = 0.05 if f_top >= 0.2 else f_top / 8.0
    sigma = problem.representative_sigma()
    doc = {
        "input": name,
        "families": {
            "step": {"amplitude": [-amp, amp], "time": [0.1 * longest, 0.5 * longest]},
            "chirp": {
                "f0": [f_low, f_top / 2],
                "f1": [f_top / 2, f_top],
                "amplitude": [0.5 * amp, amp],
            },
            "multisine": {
                "f_min": [f_low, f_top / 4],
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
