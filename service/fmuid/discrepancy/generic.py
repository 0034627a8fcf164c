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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal, stats

from fmuid.discrepancy.decide import min_p
from fmuid.discrepancy.residual_tests import TestResult
from fmuid.estimation.predictor import merged_inputs
from fmuid.estimation.problem import Problem

ORDER = 2
"""Laguerre filters per input and output (the error model's order)."""

OCTAVE = 2.0
"""Ratio of neighbouring poles of the bank."""

NAME = "generic_error_model"
"""The test's name in the decision family."""


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


def laguerre(pole_hz: float, time: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Return the first :data:`ORDER` Laguerre filters of ``u`` (linear between samples)."""
    p = 2.0 * np.pi * pole_hz
    num, den = np.array([np.sqrt(2.0 * p)]), np.array([1.0, p])
    out = []
    for _ in range(ORDER):
        _, y, _ = signal.lsim((num, den), u, time)
        out.append(y)
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


def blocks(problem: Problem, residuals: np.ndarray, basis: np.ndarray) -> list[Block]:
    """Score statistic of the error model at every pole of the bank.

    ``basis`` spans the fit's weighted sensitivities (:func:`.scan.sensitivity_basis`).
    """
    r = np.asarray(residuals, dtype=float)
    out = []
    for pole in poles_hz(problem):
        phi = regressors(problem, float(pole))
        phi = phi - basis @ (basis.T @ phi)
        q, sv, _ = np.linalg.svd(phi, full_matrices=False)
        q = q[:, sv > 1e-8 * max(float(sv.max(initial=0.0)), 1e-300)]
        if q.shape[1] == 0:
            continue
        score = q.T @ r
        statistic = float(score @ score)
        out.append(Block(float(pole), q, statistic, float(stats.chi2.sf(statistic, q.shape[1]))))
    return out


def generic_test(
    problem: Problem, residuals: np.ndarray, basis: np.ndarray, seed: int
) -> tuple[TestResult | None, Block | None]:
    """Return the generic error-model test of a fit and the pole of its smallest p-value.

    ``None`` when the problem has no inputs (nothing drives the error model).
    """
    if not problem.inputs:
        return None, None
    bank = blocks(problem, residuals, basis)
    if not bank:
        return None, None
    adjusted = min_p(bank, seed)
    k = int(np.argmin(adjusted))
    best = bank[k]
    return TestResult(NAME, None, None, adjusted[k], best.statistic, best.directions.shape[1]), best
