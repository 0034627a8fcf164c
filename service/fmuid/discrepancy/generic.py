"""A generic error-model test: input-driven structure that no move of the parameters explains.

A concealed effect that is not in the catalogue leaves the residuals looking like noise and no
candidate's likelihood ratio significant. What it cannot hide is the part of its output that
the base parameters cannot reproduce, and that part is driven by the inputs. The test asks
whether an additive, linear error model

    e_o(t) = sum_i sum_k theta_{o,i,k} (L_k(p) * u_i)(t)

(every output ``o`` and input ``i``; ``L_k(p)`` the first :data:`ORDER` continuous-time
Laguerre filters with pole ``p``; the same coefficients in every experiment) lowers chi2 by
more than noise would, once the base parameters may move too. It is a score (Lagrange
multiplier) test at the base fit: with ``J`` the weighted sensitivities and ``Phi`` the
weighted error-model regressors, the statistic is the squared norm of the residuals projected
on ``(I - P_J) Phi``, chi2 with ``rank`` degrees of freedom under the base model (exact for a
model linear in its parameters, first order otherwise). It costs no simulation.

The pole is not known in advance, so a bank of poles one octave apart spans the band the data
can see: from one cycle over the longest experiment to a quarter of the sampling rate. The
test's p-value is that of the smallest p-value over the bank, calibrated for the poles'
correlation by min-P (:func:`.decide.min_p`), as the catalogue scan is.

**Parameters pressed against a bound.** A fitted parameter at a bound of its range can move
only inward, and the residuals are not orthogonal to its sensitivity: the part of the misfit
that wants it beyond the bound is misfit that no admissible move reproduces. Its sensitivity is
therefore not projected out; it enters both fits of the statistic as a column whose
coefficient moves the parameter inward only (:func:`local_model`), so that the statistic is
the local likelihood ratio under the constraint, ``min ||r - C d||^2 - min ||r - C d - Phi b||^2``
over ``d >= 0`` (``C``: the pinned sensitivities of the weighted predictions, signed inward).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize, signal, stats

from fmuid.discrepancy.decide import generic_tie, min_p
from fmuid.discrepancy.residual_tests import TestResult
from fmuid.discrepancy.scan import CandidateFit, sensitivity_basis
from fmuid.estimation.predictor import merged_inputs
from fmuid.estimation.problem import Problem
from fmuid.estimation.space import BOUND_TOLERANCE
from fmuid.model.kept import Kept, content_key, read_only

ORDER = 2
"""Laguerre filters per input and output (the error model's order)."""

OCTAVE = 2.0
"""Ratio of neighbouring poles of the bank."""

NAME = "generic_error_model"
"""The test's name in the decision family."""

_KEPT: Kept[np.ndarray] = Kept(64)
"""Laguerre filter banks kept per process (:func:`laguerre`)."""


@dataclass(frozen=True)
class Block:
    """One pole of the bank: its projected directions and its own p-value."""

    pole_hz: float
    directions: np.ndarray
    statistic: float
    p_value: float
    one_sided: bool = False


def poles_hz(problem: Problem) -> np.ndarray:
    """Pole frequencies of the bank: octaves from 1/duration to a quarter of the rate."""
    durations, steps = [], []
    for i, exp in enumerate(problem.experiments):
        for mask in problem.masks[i]:
            t = exp.time[mask]
            if len(t) > 2:
                durations.append(float(t[-1] - t[0]))
                steps.append(float(np.median(np.diff(t))))
    if not durations:
        return np.empty(0)
    low, high = 1.0 / max(durations), 0.25 / max(steps)
    if high <= low:
        return np.array([np.sqrt(low * high)])
    n = int(np.floor(np.log(high / low) / np.log(OCTAVE))) + 1
    return low * OCTAVE ** np.arange(n)


def filtered(num: np.ndarray, den: np.ndarray, u: np.ndarray, time: np.ndarray) -> np.ndarray:
    """Response of ``num/den`` from rest to ``u``, linear between samples, on any time grid.

    Equal steps go to :func:`scipy.signal.lsim`; otherwise the exact first-order-hold
    recursion is stepped with one matrix exponential per distinct step (a repeated time, a
    step in the input given as two rows, keeps the state).
    """
    h = np.diff(time)
    if h.size == 0 or np.allclose(h, h[0], rtol=1e-9, atol=0.0):
        return np.asarray(signal.lsim((num, den), u, time)[1], dtype=float)
    a, b, c, d = signal.tf2ss(num, den)
    n = a.shape[0]
    m = np.zeros((n + 2, n + 2))
    m[:n, :n], m[:n, n], m[n, n + 1] = a, b[:, 0], 1.0
    x = np.zeros(n)
    y = np.empty(len(u))
    y[0] = float(c[0] @ x + d[0, 0] * u[0])
    steps: dict[float, np.ndarray] = {}
    for k, step in enumerate(h.tolist()):
        if step > 0:
            e = steps.get(step)
            if e is None:
                e = steps.setdefault(step, linalg.expm(m * step))
            slope = (u[k + 1] - u[k]) / step
            x = e[:n, :n] @ x + e[:n, n] * u[k] + e[:n, n + 1] * slope
        y[k + 1] = float(c[0] @ x + d[0, 0] * u[k + 1])
    return y


def laguerre(pole_hz: float, time: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Return the first :data:`ORDER` Laguerre filters of ``u`` (linear between samples).

    Kept per pole, time and input (the last 64 of them): every fit of a diagnosis
    (the base fit and each augmented one) is tested on the same inputs.
    """
    key = (float(pole_hz), *content_key(time, u))
    return _KEPT.get(key, lambda: read_only(_laguerre(pole_hz, time, u)))


def _laguerre(pole_hz: float, time: np.ndarray, u: np.ndarray) -> np.ndarray:
    p = 2.0 * np.pi * pole_hz
    num, den = np.array([np.sqrt(2.0 * p)]), np.array([1.0, p])
    out = []
    for _ in range(ORDER):
        out.append(filtered(num, den, u, time))
        num, den = np.polymul(num, [-1.0, p]), np.polymul(den, [1.0, p])
    return np.column_stack(out)


def regressors(problem: Problem, pole_hz: float) -> np.ndarray:
    """Weighted error-model regressors, row-aligned with ``problem.residuals``."""
    rows = []
    n_in, n_out = len(problem.inputs), len(problem.outputs)
    width = n_out * n_in * ORDER
    for i, exp in enumerate(problem.experiments):
        time, inputs = merged_inputs(exp, problem.inputs)
        filtered = [laguerre(pole_hz, time - time[0], inputs[name]) for name in problem.inputs]
        for j, output in enumerate(problem.outputs):
            mask = problem.masks[i][j]
            t = exp.time[mask]
            block = np.zeros((len(t), width))
            weight = 1.0 / problem.sigma[i][output][mask]
            for k, f in enumerate(filtered):
                col = (j * n_in + k) * ORDER
                for m in range(ORDER):
                    block[:, col + m] = np.interp(t, time, f[:, m]) * weight
            rows.append(block)
    return np.vstack(rows)


def local_model(
    problem: Problem, z: np.ndarray, jacobian: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Return what moves of a fit's parameters can reproduce, near the fit.

    Returns
    -------
    basis, pinned
        An orthonormal basis of the sensitivities of the weighted predictions (``jacobian``,
        as :func:`fmuid.estimation.optimize.jacobian` returns them) to the parameters inside
        their range, and those to the parameters at a bound, each signed so that a positive
        coefficient moves its parameter inward (``n_data x n_pinned``).
    """
    z = np.asarray(z, dtype=float)
    jac = np.asarray(jacobian, dtype=float)
    lo, hi = problem.z_lower, problem.z_upper
    tol = BOUND_TOLERANCE * (hi - lo)
    inward = np.where(z <= lo + tol, 1.0, np.where(z >= hi - tol, -1.0, 0.0))
    free = inward == 0.0
    return sensitivity_basis(jac[:, free]), jac[:, ~free] * inward[~free]


def _refit(a: np.ndarray, r: np.ndarray, n_pinned: int) -> np.ndarray:
    """Return ``r - a x`` at the least squares ``x`` whose first ``n_pinned`` entries are >= 0."""
    lower = np.r_[np.zeros(n_pinned), np.full(a.shape[1] - n_pinned, -np.inf)]
    return -optimize.lsq_linear(a, r, bounds=(lower, np.inf), method="bvls").fun


def constrained_drop(r: np.ndarray, phi: np.ndarray, pinned: np.ndarray) -> float:
    """Drop of ``||r - C d||^2`` (``d >= 0``) when ``Phi b`` (free) is added."""
    n = pinned.shape[1]
    null, both = _refit(pinned, r, n), _refit(np.hstack([pinned, phi]), r, n)
    return max(float(null @ null - both @ both), 0.0)


def fitted_residuals(
    residuals: np.ndarray, block: Block, model: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """Weighted residuals of the fit with the error model of ``block`` added (linearised).

    ``residuals`` are the fit's and ``model`` its :func:`local_model`: the parameters inside
    their range move freely, those at a bound inward only.
    """
    r = np.asarray(residuals, dtype=float)
    basis, pinned = model
    q = block.directions
    if not pinned.shape[1]:
        return r - q @ (q.T @ r)
    pinned_q = pinned - basis @ (basis.T @ pinned)
    return _refit(np.hstack([pinned_q, q]), r, pinned.shape[1])


def blocks(
    problem: Problem, residuals: np.ndarray, basis: np.ndarray, pinned: np.ndarray | None = None
) -> list[Block]:
    """Score statistic of the error model at every pole of the bank.

    ``basis`` spans the sensitivities of the fit's parameters inside their range and
    ``pinned`` holds those at a bound, signed inward (:func:`local_model`).
    """
    r = np.asarray(residuals, dtype=float)
    pinned_q = None
    if pinned is not None and pinned.shape[1]:
        pinned_q = pinned - basis @ (basis.T @ pinned)
    out = []
    for pole in poles_hz(problem):
        phi = regressors(problem, float(pole))
        phi = phi - basis @ (basis.T @ phi)
        q, sv, _ = np.linalg.svd(phi, full_matrices=False)
        q = q[:, sv > 1e-8 * max(float(sv.max(initial=0.0)), 1e-300)]
        if q.shape[1] == 0:
            continue
        if pinned_q is None:
            score = q.T @ r
            statistic = float(score @ score)
        else:
            statistic = constrained_drop(r, q, pinned_q)
        out.append(Block(float(pole), q, statistic, float(stats.chi2.sf(statistic, q.shape[1]))))
    return out


def generic_test(
    problem: Problem,
    residuals: np.ndarray,
    model: tuple[np.ndarray, np.ndarray],
    seed: int,
) -> tuple[TestResult | None, Block | None]:
    """Return the generic error-model test of a fit and the pole of its smallest p-value.

    ``model`` is the fit's :func:`local_model`. ``None`` when the problem has no inputs
    (nothing drives the error model).
    """
    if not problem.inputs:
        return None, None
    bank = blocks(problem, residuals, *model)
    if not bank:
        return None, None
    adjusted = min_p(bank, seed)
    k = int(np.argmin(adjusted))
    best = bank[k]
    return TestResult(NAME, None, None, adjusted[k], best.statistic, best.directions.shape[1]), best


def describe(block: Block) -> str:
    """Return the error model of a pole of the bank in words."""
    return f"Laguerre filters of each input (pole {block.pole_hz:.3g} Hz) per output"


def generic_rival(
    best: CandidateFit,
    residuals: np.ndarray,
    block: Block,
    model: tuple[np.ndarray, np.ndarray],
    n_free: int,
) -> dict[str, object] | None:
    """Return the generic error model at ``block`` as a tie of ``best``, if it is one.

    ``residuals``, ``model`` and ``n_free`` are the base fit's (:func:`.decide.generic_tie`).
    """
    fitted = fitted_residuals(residuals, block, model)
    return generic_tie(best, fitted, n_free + block.directions.shape[1], describe(block))
