"""Scan the catalogue: every candidate's likelihood-ratio statistic against the base fit.

A concealed effect is one that the base fit hides by moving its parameters; what it cannot
hide is the part of the effect that no move of the base parameters reproduces. The scan
therefore works in two steps per candidate:

1. **Linearised screen** (a few simulations). For the added parameter at a grid of values
   ``g`` (and at the optimum of the linear approximation, and near a threshold's onset:
   :mod:`.onset`), the change of the weighted residuals ``d_g = r_0 - r(g)`` is computed by
   simulation, and the base parameters are
   re-adjusted to first order: ``chi2_lin(g) = ||(I - P) r(g)||^2`` with ``P`` the projection
   onto the base fit's sensitivities. The drop ``chi2_lin(off) - min_g chi2_lin(g)`` is the
   screen statistic. The direction ``u = (I - P) d`` at the smallest effect (the probe) is the
   candidate's score direction, used for the null distribution (:mod:`.decide`).
2. **Full fit** of the candidates that the screen cannot rule out (screen p below
   ``screen_level``, and at least the ``min_fits`` strongest): trust-region least squares of
   every parameter from the screen's best point, the base parameters moved by the
   Gauss-Newton step. The likelihood-ratio statistic is the chi2 drop against the base fit.

The null distribution of a statistic whose parameter is off at a bound (a lag or a delay at 0,
a saturation angle at infinity) is the chi-bar-square mixture ``1/2 chi2_0 + 1/2 chi2_1``;
otherwise chi2 with as many degrees of freedom as added parameters.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any, TypeVar

import numpy as np
from scipy import stats

from fmuid.discrepancy.augment import AugmentedPredictor
from fmuid.discrepancy.effects import Effect, OutputSaturation
from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.discrepancy.onset import onset_levels
from fmuid.discrepancy.threshold import ClipNull, LevelsNull, ThresholdNull, unit_columns
from fmuid.errors import FmuidError
from fmuid.estimation.optimize import FitOptions, Mapper, refine, safe_residuals
from fmuid.estimation.predictor import FmuPredictor
from fmuid.estimation.problem import Problem

log = logging.getLogger(__name__)

T = TypeVar("T")

GRID_POINTS = 7
"""Grid values of a one-parameter candidate's added parameter in the screen."""

PROBE_FRACTION = 0.05
"""Probe of a parameter whose off value lies inside its bounds: off + this share of the
distance to the farther bound."""


@dataclass(frozen=True)
class CandidateFit:
    """A candidate scored against the model it augments.

    Attributes
    ----------
    candidate
        The candidate.
    problem
        The augmented problem.
    z
        Its best point found (fitted coordinates).
    chi2
        Chi2 at ``z``.
    statistic
        Likelihood-ratio statistic: chi2 of the model it augments minus ``chi2`` (>= 0).
    p_value
        Boundary-aware p-value of ``statistic`` for this candidate alone.
    one_sided
        Whether the off value is at a bound (chi-bar-square null).
    fitted
        ``True`` after a full fit; ``False`` when only the linearised screen ran.
    residuals
        Weighted residuals at ``z`` (for the tests between non-nested candidates).
    directions
        Orthonormal score directions of the added parameters, base sensitivities projected
        out (one column per added parameter).
    stage
        1 on the base model, 2 on top of a first effect.
    null
        A threshold's null of ``statistic`` (:mod:`.threshold`); ``None``: ``p_value``'s.

    """

    candidate: Effect
    problem: Problem
    z: np.ndarray
    chi2: float
    statistic: float
    p_value: float
    one_sided: bool
    fitted: bool
    residuals: np.ndarray
    directions: np.ndarray
    stage: int = 1
    null: ThresholdNull | None = None

    @property
    def values(self) -> dict[str, float]:
        """Fitted values of the added parameters."""
        all_values = self.problem.from_z(self.z)
        return {name: all_values[name] for name in self.candidate.names}

    @property
    def bic(self) -> float:
        """``chi2 + k ln(n)`` of the augmented model."""
        return self.chi2 + self.problem.n_free * float(np.log(self.problem.n_data))


def null_p_value(statistic: float, df: int, one_sided: bool) -> float:
    """P-value of a likelihood-ratio statistic: chi-bar-square at a bound, else chi2(df)."""
    if one_sided and df == 1:
        return 1.0 if statistic <= 0 else 0.5 * float(stats.chi2.sf(statistic, 1))
    return float(stats.chi2.sf(max(statistic, 0.0), df))


def sensitivity_basis(jacobian: np.ndarray) -> np.ndarray:
    """Orthonormal basis of what a move of the fitted parameters reproduces (columns)."""
    u, s, _ = np.linalg.svd(np.asarray(jacobian, dtype=float), full_matrices=False)
    return u[:, s > 1e-10 * max(float(s.max(initial=0.0)), 1e-300)]


def augmented(
    root: Problem, candidates: Sequence[Effect], step_scale: float | None = None
) -> Problem:
    """Return the root problem with the effects' parameters added and the effects applied.

    With no effect, the root problem simulated as its augmentations are (on their fine input
    grid when the FMU needs it: :attr:`AugmentedPredictor.fine_inputs`). The fine step is the
    root's (an augmented root's refined step, :mod:`.coupling`) unless ``step_scale`` is given.
    """
    params = dict(root.parameter_specs)
    for c in candidates:
        for p in c.parameters:
            params[p.name] = p.spec
    base = root.predictor
    effects = tuple(candidates)
    scale = 1.0
    if isinstance(base, AugmentedPredictor):
        effects, scale = (*base.effects, *effects), base.step_scale
        base = base.base
    scale = scale if step_scale is None else step_scale
    wrapped = AugmentedPredictor(base, effects, scale) if isinstance(base, FmuPredictor) else None
    predictor = wrapped if wrapped is not None and (effects or wrapped.fine_inputs) else base
    return Problem(
        root.fmu_path,
        root.experiments,
        root.spec,
        predictor=predictor,
        parameters=params,
        sigma=root.sigma,
        sigma_method=root.sigma_method,
        model=root.model,
    )


def _probe(p: AddedParameter) -> float:
    """Return the smallest effect of a parameter: its probe, the bound next to off, or a step."""
    if p.probe is not None:
        return p.probe
    if p.off_side == "low":
        return p.spec.lower
    if p.off_side == "high":
        return p.spec.upper
    far = p.spec.upper if p.spec.upper - p.off >= p.off - p.spec.lower else p.spec.lower
    return p.off + PROBE_FRACTION * (far - p.off)


def _from_step(p: AddedParameter, probe: float, theta: float) -> float | None:
    """Parameter value of ``theta`` probe-sized effects (``None`` when it cannot be reached).

    A threshold (a parameter with its own grid) is not linear in its effect: its grid decides.
    """
    if p.grid and p.off_side != "inside":
        return None
    if p.off_side == "high":  # the effect grows like 1 / value^2 (a saturation angle)
        return probe / np.sqrt(theta) if theta > 0 else None
    if p.off_side == "low" and theta <= 0:
        return None
    value = p.off + theta * (probe - p.off)
    return float(np.clip(value, p.spec.lower, p.spec.upper))


def _grid(p: AddedParameter) -> np.ndarray:
    if p.grid:
        return np.asarray(p.grid, dtype=float)
    lo, hi = p.spec.lower, p.spec.upper
    if p.spec.resolved_scale == "log":
        return np.logspace(np.log10(lo), np.log10(hi), GRID_POINTS)
    return np.linspace(lo, hi, GRID_POINTS)


class Scanner:
    """Scores candidates against one fitted model (the base model, or a first augmentation).

    Parameters
    ----------
    problem
        The model the candidates augment.
    z
        Its best fit (fitted coordinates).
    jacobian
        Sensitivities of its weighted predictions at ``z`` (``n_data x n_free``).

    """

    def __init__(self, problem: Problem, z: np.ndarray, jacobian: np.ndarray):
        self.problem = problem
        self.z = np.asarray(z, dtype=float)
        self.values = problem.from_z(self.z)
        self.r0 = safe_residuals(problem, self.z)
        self.chi2 = float(self.r0 @ self.r0)
        self.jac = np.asarray(jacobian, dtype=float)
        self.basis = sensitivity_basis(self.jac)
        self.rows = _output_rows(problem)

    def threshold_null(self, candidate: Effect, levels: np.ndarray) -> ThresholdNull | None:
        """Return the null of a threshold's statistic (``levels``: its screened levels' ``d_g``).

        An output limit's is exact in the level (:class:`~.threshold.ClipNull`); an input
        threshold's runs over the screened levels (:class:`~.threshold.LevelsNull`).
        """
        if not candidate.threshold:
            return None
        if isinstance(candidate, OutputSaturation) and candidate.target in self.rows:
            rows, data, weight = self.rows[candidate.target]
            spec = candidate.parameters[0].spec
            floor = spec.lower if candidate.upper else spec.upper
            predicted = data - self.r0[rows] / weight
            return ClipNull.build(rows, predicted, weight, self.basis, floor, candidate.upper)
        return LevelsNull(unit_columns(self.project(levels)))

    def project(self, v: np.ndarray) -> np.ndarray:
        """``(I - P) v``: what no move of the base parameters reproduces."""
        return v - self.basis @ (self.basis.T @ v)

    def _residuals_at(self, aug: Problem, added: dict[str, float]) -> np.ndarray:
        return safe_residuals(aug, aug.to_z({**self.values, **added}))

    def screen(self, candidate: Effect, stage: int = 1) -> CandidateFit:
        """Linearised screen of one candidate (see the module docstring)."""
        aug = augmented(self.problem, [candidate])
        params = candidate.parameters
        probes = {p.name: _probe(p) for p in params}
        off = {p.name: p.off for p in params}
        raw = []
        for p in params:  # one parameter at its probe, the others off (valid FMU values)
            with np.errstate(divide="ignore"):
                trial = {**off, p.name: probes[p.name]}
                raw.append(self.r0 - self._residuals_at(aug, trial))
        d = np.column_stack(raw)
        u = self.project(d)
        q, rank_s, _ = np.linalg.svd(u, full_matrices=False)
        directions = q[:, rank_s > 1e-12 * max(float(rank_s.max(initial=0.0)), 1e-300)]
        theta = np.linalg.lstsq(u, self.r0, rcond=None)[0]
        points: list[dict[str, float]] = []
        if len(params) == 1:
            (p,) = params
            points = [{p.name: float(g)} for g in _grid(p)]
            best = _from_step(p, probes[p.name], float(theta[0]))
            if best is not None:
                points.append({p.name: best})
        else:
            reached = [_from_step(p, probes[p.name], float(t)) for p, t in zip(params, theta)]
            points.append(
                {p.name: off[p.name] if v is None else v for p, v in zip(params, reached)}
            )
        evaluated = [(point, self._residuals_at(aug, point)) for point in points]
        if len(params) == 1:  # p: the one parameter (above)
            tried = [(point[p.name], r) for point, r in evaluated]
            near = onset_levels(p, tried, partial(self._residuals_at, aug), self.r0)
            evaluated += [({p.name: v}, r) for v, r in near]
        base_lin = float(self.project(self.r0) @ self.project(self.r0))
        best_point, best_chi2, best_r = None, base_lin, self.r0
        changes = []
        for point, r in evaluated:
            changes.append(self.r0 - r)
            rp = self.project(r)
            chi2_lin = float(rp @ rp)
            if chi2_lin < best_chi2:
                best_point, best_chi2, best_r = point, chi2_lin, r
        one_sided = len(params) == 1 and params[0].off_side != "inside"
        statistic = max(base_lin - best_chi2, 0.0)
        start = {**self.values, **(best_point or {p.name: probes[p.name] for p in params})}
        z_start = aug.to_z(start)
        step = np.linalg.lstsq(self.jac, best_r, rcond=None)[0]
        n_base = self.problem.n_free
        z_start[:n_base] = np.clip(
            z_start[:n_base] + step, self.problem.z_lower, self.problem.z_upper
        )
        return CandidateFit(
            candidate,
            aug,
            z_start,
            self.chi2 - statistic,
            statistic,
            null_p_value(statistic, len(params), one_sided),
            one_sided,
            False,
            best_r,
            directions,
            stage,
            self.threshold_null(candidate, np.column_stack(changes) if changes else d),
        )

    def fit(self, screened: CandidateFit, options: FitOptions) -> CandidateFit:
        """Fit every parameter of a screened candidate from the screen's best point."""
        aug = screened.problem
        try:
            z, chi2, _ = refine(aug, screened.z, options=options)
        except FmuidError as exc:
            log.info("%s: fit failed (%s); the screen stands", screened.candidate.label, exc)
            return screened
        r = safe_residuals(aug, z)
        chi2 = float(r @ r)
        statistic = max(self.chi2 - chi2, 0.0)
        df = len(screened.candidate.parameters)
        return CandidateFit(
            screened.candidate,
            aug,
            z,
            chi2,
            statistic,
            null_p_value(statistic, df, screened.one_sided),
            screened.one_sided,
            True,
            r,
            screened.directions,
            screened.stage,
            screened.null,
        )


def _output_rows(problem: Problem) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Each output's indices in the residual vector, its data and ``1/sigma`` there."""
    parts: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
    start = 0
    for masks, data, sigma in zip(problem.masks, problem.data, problem.sigma):
        for j, o in enumerate(problem.outputs):
            n = int(masks[j].sum())
            rows = np.arange(start, start + n)
            parts.setdefault(o, []).append((rows, data[j], 1.0 / sigma[o][masks[j]]))
            start += n
    return {
        o: tuple(np.concatenate([p[k] for p in ps]) for k in range(3))  # type: ignore[misc]
        for o, ps in parts.items()
    }


def screen_task(scanner: Scanner, candidate: Effect, stage: int) -> CandidateFit:
    """Screen one candidate (a task of a worker process)."""
    return scanner.screen(candidate, stage)


def fit_task(scanner: Scanner, screened: CandidateFit, options: FitOptions) -> CandidateFit:
    """Fit one screened candidate (a task of a worker process)."""
    return scanner.fit(screened, options)


def serial(fn: Callable[..., T], *iterables: Sequence[Any]) -> list[T]:
    """Map in this process (the default :data:`Mapper`)."""
    return list(map(fn, *iterables))


def scan(
    scanner: Scanner,
    candidates: Sequence[Effect],
    *,
    screen_level: float,
    min_fits: int,
    options: FitOptions,
    stage: int = 1,
    on_candidate: object = None,
    mapper: Mapper = serial,
) -> list[CandidateFit]:
    """Screen every candidate, fully fit those the screen cannot rule out; sorted by chi2.

    ``mapper`` runs the screens, then the fits (:func:`fmuid.discrepancy.tasks.candidate_pool`:
    side by side in worker processes; the results do not depend on it).
    """
    n = len(candidates)
    screened = mapper(screen_task, [scanner] * n, list(candidates), [stage] * n)
    order = sorted(range(n), key=lambda i: screened[i].p_value)
    chosen = [i for k, i in enumerate(order) if k < min_fits or screened[i].p_value < screen_level]
    chosen.sort()
    k = len(chosen)
    fitted = mapper(fit_task, [scanner] * k, [screened[i] for i in chosen], [options] * k)
    fits = dict(zip(chosen, fitted, strict=True))
    out = [fits.get(i, s) for i, s in enumerate(screened)]
    if callable(on_candidate):
        for f in out:
            on_candidate(f)
    return sorted(out, key=lambda f: (f.bic, f.chi2))
