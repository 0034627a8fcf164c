"""Check a design the way the user will: profile likelihoods on simulated noisy data."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from fmuid.data import Spec
from fmuid.engine.run import open_engine
from fmuid.estimation.optimize import fit_problem
from fmuid.estimation.problem import Problem
from fmuid.experiment_design.fisher import trial_problem
from fmuid.experiment_design.signals import Trial
from fmuid.experiment_design.space import Space
from fmuid.model.fmu import FmuModel
from fmuid.profiling.engine import profile_problem


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


@dataclass(frozen=True)
class Draw:
    """Profiles of one design on one noise draw (one task of the verification).

    Attributes
    ----------
    identifiable, open_ended
        Per free parameter (spec order): labelled identifiable; a simultaneous CI end open.
    widths
        Per free parameter: simultaneous CI width (as :class:`Verification` counts it).
    simulations, seconds
        Cost of the fit and the profiles.

    """

    identifiable: tuple[bool, ...]
    open_ended: tuple[bool, ...]
    widths: tuple[float, ...]
    simulations: int
    seconds: float

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Return the checkpoint form (exact)."""
        return {
            "identifiable": np.array(self.identifiable, dtype=bool),
            "open_ended": np.array(self.open_ended, dtype=bool),
            "widths": np.array(self.widths, dtype=float),
            "cost": np.array([self.simulations, self.seconds]),
        }

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> Draw:
        """Return the draw a checkpoint holds."""
        return cls(
            tuple(bool(v) for v in arrays["identifiable"]),
            tuple(bool(v) for v in arrays["open_ended"]),
            tuple(float(v) for v in arrays["widths"]),
            int(arrays["cost"][0]),
            float(arrays["cost"][1]),
        )


@dataclass(frozen=True)
class DrawTask:
    """One verification evaluation: profile ``trial`` on noise draw ``draw`` of ``seed``."""

    model: FmuModel
    spec: Spec
    space: Space
    trial: Trial
    seed: int
    draw: int

    def run(self) -> Draw:
        """Simulate the draw at the spec's start values, fit it from the truth, profile it.

        The fit takes no global search (as the thesis study did); the profiles run in this
        process with the engine of ``fmuid profile``.
        """
        truth = {n: float(p.start) for n, p in self.spec.parameters.items()}
        rng = np.random.default_rng((self.seed, self.draw))
        problem = noisy_problem(self.model, self.spec, self.space, self.trial, truth, rng)
        fit = fit_problem(problem, start=truth, global_search=False)
        prof = profile_problem(problem, fit, workers=1)
        ident, opened, widths = [], [], []
        for i, name in enumerate(problem.names):
            p = prof.parameters[name]
            ident.append(p.status == "identifiable")
            opened.append(None in p.ci_simultaneous)
            lo = p.ci_simultaneous[0] if p.ci_simultaneous[0] is not None else problem.lower[i]
            hi = p.ci_simultaneous[1] if p.ci_simultaneous[1] is not None else problem.upper[i]
            log_scaled = problem.scales[i] == "log"
            widths.append(float(np.log10(hi) - np.log10(lo)) if log_scaled else float(hi - lo))
        return Draw(
            tuple(ident), tuple(opened), tuple(widths), prof.cost.simulations, prof.cost.seconds
        )


def combine(names: Sequence[str], draws: Sequence[Draw]) -> Verification:
    """Return the verification of a design from its draws."""
    return Verification(
        len(draws),
        {n: sum(d.identifiable[i] for d in draws) for i, n in enumerate(names)},
        {n: sum(d.open_ended[i] for d in draws) for i, n in enumerate(names)},
        {n: [d.widths[i] for d in draws] for i, n in enumerate(names)},
        sum(d.simulations for d in draws),
        sum(d.seconds for d in draws),
    )


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
    """Profile the design on ``space.draws`` noisy datasets (one :class:`DrawTask` each).

    ``workers`` local processes or the dask ``executor`` take one draw each.
    """
    tasks = [DrawTask(model, spec, space, trial, seed, d) for d in range(space.draws)]
    with open_engine(
        model.with_interface(spec.interface),
        workers=workers,
        executor=executor,
        at_most=len(tasks),
        preload=[__name__],
    ) as engine:
        draws = engine.map(DrawTask.run, tasks)
    return combine(list(spec.parameters), draws)
