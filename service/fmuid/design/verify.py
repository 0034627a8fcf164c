"""Check a design the way the user will: profile likelihoods on simulated noisy data."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fmuid.data import Spec
from fmuid.design.fisher import trial_problem
from fmuid.design.signals import Trial
from fmuid.design.space import Space
from fmuid.fit.optimize import fit_problem
from fmuid.fit.problem import Problem
from fmuid.model.fmu import FmuModel
from fmuid.profile.engine import profile_problem


@dataclass(frozen=True)
class Verification:
    """Profiles of one design over several noise draws.

    Attributes
    ----------
    draws
        Number of noise draws profiled.
    identifiable
        Parameter -> draws in which its profile labelled it identifiable.
    open_ended
        Parameter -> draws in which a simultaneous CI end was open (not crossed in the bounds).
    widths
        Parameter -> simultaneous CI width per draw [decades for log-scaled parameters, else
        the parameter's unit]; an open end counts at the parameter's bound (a lower limit).
    simulations, seconds
        Cost of the fits and profiles.

    """

    draws: int
    identifiable: dict[str, int]
    open_ended: dict[str, int]
    widths: dict[str, list[float]]
    simulations: int
    seconds: float

    def median_width(self, name: str) -> float:
        """Median simultaneous CI width of a parameter over the draws."""
        return float(np.median(self.widths[name]))

    def geometric_mean_width(self) -> float:
        """Geometric mean over the parameters of the median widths."""
        w = np.array([self.median_width(n) for n in self.widths])
        return float(np.exp(np.mean(np.log(np.maximum(w, 1e-300)))))

    def to_dict(self) -> dict[str, object]:
        """Return the JSON form."""
        return {
            "draws": self.draws,
            "identifiable": dict(self.identifiable),
            "open_ended": dict(self.open_ended),
            "median_width": {n: self.median_width(n) for n in self.widths},
            "width_unit": "decades (log-scaled parameters); open ends at the bound",
        }


def noisy_problem(
    model: FmuModel,
    spec: Spec,
    space: Space,
    trial: Trial,
    truth: Mapping[str, float],
    rng: np.random.Generator,
) -> Problem:
    """Simulate the trial at ``truth`` with Gaussian noise at the space's sigma; its problem."""
    template = trial_problem(model, spec, space, trial)
    clean = template.predict(truth)[0]
    mask = template.masks[0][0]
    values = {
        o: clean[o][mask] + rng.normal(0.0, space.outputs[o].sigma, int(mask.sum()))
        for o in trial.outputs
    }
    return trial_problem(model, spec, space, trial, values)


def verify(
    model: FmuModel,
    spec: Spec,
    space: Space,
    trial: Trial,
    *,
    seed: int,
    workers: int | None = 1,
    executor: object = None,
) -> Verification:
    """Profile the design on ``space.draws`` noisy datasets simulated at the spec's start values.

    Each draw is fitted from the truth (no global search, as the thesis study did) and every
    free parameter is profiled with the same engine as ``fmuid profile``.
    """
    truth = {n: float(p.start) for n, p in spec.parameters.items()}
    identifiable = dict.fromkeys(spec.parameters, 0)
    widths: dict[str, list[float]] = {n: [] for n in spec.parameters}
    opened = dict.fromkeys(spec.parameters, 0)
    sims, seconds = 0, 0.0
    for draw in range(space.draws):
        rng = np.random.default_rng((seed, draw))
        problem = noisy_problem(model, spec, space, trial, truth, rng)
        fit = fit_problem(problem, start=truth, global_search=False)
        prof = profile_problem(problem, fit, workers=workers, executor=executor)
        sims += prof.cost.simulations
        seconds += prof.cost.seconds
        for i, name in enumerate(problem.names):
            p = prof.parameters[name]
            identifiable[name] += p.status == "identifiable"
            lo = p.ci_simultaneous[0] if p.ci_simultaneous[0] is not None else problem.lower[i]
            hi = p.ci_simultaneous[1] if p.ci_simultaneous[1] is not None else problem.upper[i]
            opened[name] += None in p.ci_simultaneous
            if problem.scales[i] == "log":
                widths[name].append(float(np.log10(hi) - np.log10(lo)))
            else:
                widths[name].append(float(hi - lo))
    return Verification(space.draws, identifiable, opened, widths, sims, seconds)
