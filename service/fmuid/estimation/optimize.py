"""Global start by pymoo's genetic algorithm, refinement by scipy's trust-region least squares."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.core.problem import Problem as PymooProblem
from pymoo.optimize import minimize as pymoo_minimize
from scipy.optimize import least_squares, minimize

from fmuid.engine.count import Count, counting
from fmuid.errors import FitError, FmuError
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import Cost, FitResult
from fmuid.model.registry import fmu_summary
from fmuid.progress import Progress, ProgressCallback

log = logging.getLogger(__name__)

#: Penalty residual per sample when a simulation fails inside an optimiser.
FAILED_RESIDUAL = 1e4

SLOW_RUN = 0.02
"""Seconds per simulation from which the genetic algorithm's later generations are evaluated
side by side by a mapper: below it a task's overhead (the problem pickled to a worker) would
cost about what it saves."""

GA_TASKS = 8
"""Tasks per generation evaluated side by side (each a share of the population)."""

Mapper = Callable[..., list[Any]]
"""``mapper(fn, *iterables)``: the results of ``fn`` over the iterables, in order."""


@dataclass(frozen=True)
class FitOptions:
    """Settings of the fit.

    Attributes
    ----------
    pop_size, generations
        Genetic algorithm size; the population is at least ``pop_size`` and ``8 n`` individuals.
    ftol, xtol, gtol
        Tolerances of ``least_squares``.
    max_nfev
        Cap on residual evaluations of one trust-region run (``None``: 100 (n + 1)).
    diff_step
        Relative finite-difference step of the Jacobian in fitted coordinates.
    polish
        After the trust-region run, polish with Powell's derivative-free method (for
        objectives with jumps, where finite differences mislead).

    """

    pop_size: int = 24
    generations: int = 25
    ftol: float = 1e-10
    xtol: float = 1e-10
    gtol: float = 1e-10
    max_nfev: int | None = None
    diff_step: float = 1e-6
    polish: bool = False


def safe_residuals(problem: Problem, z: np.ndarray) -> np.ndarray:
    """Residuals, or a large constant vector when the simulation fails."""
    try:
        return problem.residuals(z)
    except FmuError as exc:
        log.debug("simulation failed at z=%s: %s", z, exc)
        return np.full(problem.n_data, FAILED_RESIDUAL)


def refine(
    problem: Problem,
    z0: np.ndarray,
    *,
    free: np.ndarray | None = None,
    options: FitOptions = FitOptions(),
    on_residuals: Callable[[np.ndarray], None] | None = None,
    stop: Callable[[np.ndarray, float], bool] | None = None,
) -> tuple[np.ndarray, float, str]:
    """Trust-region reflective least squares in fitted coordinates within the bounds.

    Parameters
    ----------
    problem
        The estimation problem.
    z0
        Start in fitted coordinates (all parameters).
    free
        Boolean mask of the parameters to move; the others stay at ``z0``.
    options
        Tolerances and step settings.
    on_residuals
        Called with the weighted residuals of every evaluation (e.g. to report progress).
    stop
        Called with every evaluated point (all parameters) and its chi2; ``True`` ends the run
        there and returns that point (no polish).

    Returns
    -------
    z, chi2, message
        The refined point (all parameters), its chi2 and the optimiser's message.

    Raises
    ------
    FmuError
        When the simulation fails at the final point.
    FitError
        When the simulation failed at every trial point.

    """
    free = np.ones(problem.n_free, bool) if free is None else free
    lo, hi = problem.z_lower[free], problem.z_upper[free]
    z_full = np.array(z0, dtype=float)
    x0 = np.clip(z_full[free], lo, hi)
    span = hi - lo
    x0 = np.where(x0 <= lo, lo + 1e-9 * span, np.where(x0 >= hi, hi - 1e-9 * span, x0))

    def fun(x: np.ndarray) -> np.ndarray:
        z = z_full.copy()
        z[free] = x
        residuals = safe_residuals(problem, z)
        if on_residuals is not None:
            on_residuals(residuals)
        if stop is not None and stop(z, float(residuals @ residuals)):
            raise _Stopped(z, float(residuals @ residuals))
        return residuals

    n_free = int(free.sum())
    try:
        res = least_squares(
            fun,
            x0,
            bounds=(lo, hi),
            method="trf",
            diff_step=options.diff_step,
            ftol=options.ftol,
            xtol=options.xtol,
            gtol=options.gtol,
            max_nfev=options.max_nfev or 100 * (n_free + 1),
            x_scale="jac",
        )
    except _Stopped as stopped:
        return stopped.z, stopped.chi2, "stopped by the caller"
    if np.all(res.fun == FAILED_RESIDUAL):
        raise FitError(f"{problem.fmu_path.name}: the simulation failed at every trial point")
    x, chi2, message = res.x, float(2.0 * res.cost), str(res.message)
    if options.polish:
        pol = minimize(
            lambda xx: float(np.sum(fun(xx) ** 2)),
            x,
            method="Powell",
            bounds=list(zip(lo, hi, strict=True)),
            options={"xtol": 1e-6, "ftol": 1e-10, "maxfev": 60 * n_free},
        )
        if pol.fun < chi2:
            x, chi2, message = pol.x, float(pol.fun), f"{message}; polished (Powell)"
    z_full[free] = x
    return z_full, chi2, message


class _Stopped(Exception):
    """Raised inside :func:`refine`'s objective to end the run at a point its caller accepts."""

    def __init__(self, z: np.ndarray, chi2: float) -> None:
        super().__init__("stopped")
        self.z, self.chi2 = z.copy(), chi2


def chi2_of(problem: Problem, zs: np.ndarray) -> list[float]:
    """Chi2 at each row of ``zs`` (a failed simulation: its penalty); the same in any process."""
    return [float(r @ r) for r in (safe_residuals(problem, z) for z in zs)]


class _GaProblem(PymooProblem):
    """The fit as pymoo's problem; a generation is evaluated side by side once runs are slow.

    The first generation runs here and times the simulations; from :data:`SLOW_RUN` seconds per
    run on, ``mapper`` evaluates the later ones in :data:`GA_TASKS` shares. Each chi2 is the
    same wherever it is computed, so the search does not depend on it.
    """

    def __init__(self, problem: Problem, mapper: Mapper | None):
        super().__init__(n_var=problem.n_free, n_obj=1, xl=problem.z_lower, xu=problem.z_upper)
        self.problem = problem
        self.mapper = mapper
        self.side_by_side = False

    def _evaluate(self, x: np.ndarray, out: dict, *args: object, **kwargs: object) -> None:
        if self.side_by_side and self.mapper is not None:
            shares = np.array_split(x, min(len(x), GA_TASKS))
            f = np.concatenate(self.mapper(chi2_of, [self.problem] * len(shares), shares))
        else:
            t0 = time.perf_counter()
            f = np.array(chi2_of(self.problem, x))
            slow = (time.perf_counter() - t0) / max(len(x), 1) >= SLOW_RUN
            self.side_by_side = slow and self.mapper is not None
        out["F"] = f


def global_start(
    problem: Problem,
    seed: int,
    options: FitOptions = FitOptions(),
    progress: ProgressCallback | None = None,
    mapper: Mapper | None = None,
) -> np.ndarray:
    """Best point of a seeded genetic algorithm over the bounds box in fitted coordinates.

    ``mapper`` evaluates generations side by side where simulations are slow (:class:`_GaProblem`).
    """
    pop = max(options.pop_size, 8 * problem.n_free)
    done = [0]

    def callback(algorithm: object) -> None:
        done[0] += 1
        if progress:
            progress(Progress("fit", done[0], options.generations, "genetic algorithm"))

    algorithm = GA(pop_size=pop, eliminate_duplicates=True)
    res = pymoo_minimize(
        _GaProblem(problem, mapper),
        algorithm,
        ("n_gen", options.generations),
        seed=seed,
        verbose=False,
        callback=callback,
    )
    return np.asarray(res.X, dtype=float).reshape(-1)


def fit_problem(
    problem: Problem,
    *,
    start: Mapping[str, float] | None = None,
    global_search: bool = True,
    seed: int = 0,
    options: FitOptions = FitOptions(),
    progress: ProgressCallback | None = None,
    mapper: Mapper | None = None,
) -> FitResult:
    """Fit the free parameters: GA global start (optional), then trust-region refinement.

    Parameters
    ----------
    problem
        The estimation problem.
    start
        Start values (parameter units); default the spec's ``start``.
    global_search
        Run the genetic algorithm first and refine from its best point (and from ``start``,
        keeping the better); otherwise refine from ``start`` only.
    seed
        Seed of the genetic algorithm.
    options
        Sizes and tolerances.
    progress
        Receives progress events.
    mapper
        Evaluates the genetic algorithm's generations side by side where simulations are slow
        (a task engine's ``map``); the fit is the same without it.

    Returns
    -------
    FitResult

    """
    t0 = time.perf_counter()
    with counting() as count:
        z, chi2, message, jac = _best_fit(
            problem, start, global_search, seed, options, progress, mapper
        )
    cost = Cost(count.simulations, time.perf_counter() - t0)
    return make_fit_result(problem, z, chi2, jac, message, global_search, cost)


def _best_fit(
    problem: Problem,
    start: Mapping[str, float] | None,
    global_search: bool,
    seed: int,
    options: FitOptions,
    progress: ProgressCallback | None,
    mapper: Mapper | None,
) -> tuple[np.ndarray, float, str, np.ndarray]:
    """Refine from each start (the global search's best first); return the best and its Jacobian."""
    z_start = problem.to_z(start) if start is not None else problem.to_z_array(problem.start)
    starts = [z_start]
    if global_search:
        starts.insert(0, global_start(problem, seed, options, progress, mapper))
    best: tuple[np.ndarray, float, str] | None = None
    errors = []
    for k, z0 in enumerate(starts, 1):
        try:
            with counting() as runs:
                label = f"start {k}/{len(starts)}"
                report = RefineProgress(progress, label, runs) if progress else None
                z, chi2, message = refine(problem, z0, options=options, on_residuals=report)
        except (FmuError, FitError) as exc:
            errors.append(str(exc))
            continue
        if best is None or chi2 < best[1]:
            best = (z, chi2, message)
    if best is None:
        raise FitError(f"the fit failed: {'; '.join(errors)}")
    z, chi2, message = best
    return z, chi2, message, jacobian(problem, z)


class RefineProgress:
    """Report the trust-region refinement: evaluations, best chi2 and simulations so far.

    ``runs`` is the count open around the refinement.

    Its events are stage ``"refine"`` with ``total`` 0 (the number of evaluations is not known
    ahead), at most one every 0.5 s.
    """

    def __init__(self, progress: ProgressCallback, label: str, runs: Count):
        self.progress = progress
        self.label = label
        self.runs = runs
        self.evaluations = 0
        self.best = float("inf")
        self.last = 0.0

    def __call__(self, residuals: np.ndarray) -> None:
        """Count one evaluation; report now and then."""
        self.evaluations += 1
        self.best = min(self.best, float(residuals @ residuals))
        now = time.monotonic()
        if now - self.last >= 0.5:
            self.last = now
            detail = f"{self.label}, chi2 {self.best:.4g}, {self.runs.simulations} simulations"
            self.progress(Progress("refine", self.evaluations, 0, detail))


def jacobian(problem: Problem, z: np.ndarray, step: float = 1e-4) -> np.ndarray:
    """Central-difference Jacobian of the weighted residuals in fitted coordinates.

    Steps stay inside the bounds (one-sided at a bound).
    """
    lo, hi = problem.z_lower, problem.z_upper
    cols = []
    for i in range(problem.n_free):
        h = step * max(1.0, abs(z[i]))
        zp, zm = z.copy(), z.copy()
        zp[i] = min(z[i] + h, hi[i])
        zm[i] = max(z[i] - h, lo[i])
        cols.append((safe_residuals(problem, zp) - safe_residuals(problem, zm)) / (zp[i] - zm[i]))
    return -np.column_stack(cols)


def make_fit_result(
    problem: Problem,
    z: np.ndarray,
    chi2: float,
    jac: np.ndarray,
    message: str,
    global_search: bool,
    cost: Cost,
) -> FitResult:
    """Assemble a ``FitResult`` for the point ``z`` of ``problem``, which cost ``cost``."""
    return FitResult(
        fmu_sha256=problem.model.sha256,
        model_name=problem.model.model_name,
        names=problem.names,
        scales=problem.scales,
        lower=dict(zip(problem.names, map(float, problem.lower), strict=True)),
        upper=dict(zip(problem.names, map(float, problem.upper), strict=True)),
        estimates=problem.from_z(z),
        chi2=chi2,
        n_data=problem.n_data,
        sigma=problem.representative_sigma(),
        sigma_method=dict(problem.sigma_method),
        jacobian=jac,
        fixed=dict(problem.spec.fixed),
        global_search=global_search,
        message=message,
        cost=cost,
        fmu_info=fmu_summary(problem.model),
        units=problem.units(),
    )
