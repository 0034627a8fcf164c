"""The fine step of a feedback term is refined until chi2 no longer feels it, against scipy.

A two-tank FMU (pythonfmu, no input derivatives: its feedback coupling is first order in the
step) misses a quadratic outflow of the upper tank, ``tau1 h1' = K u - h1 - q h1^2``. The
feedback candidate ``c2_h1_u`` (``-q/K`` times ``h1^2`` added to ``u``) is the exact
augmentation. The reference is scipy's least-squares fit of that closed-loop equation, solved by
``solve_ivp``: an augmented fit on a fine enough step must reach its chi2.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.discrepancy.catalogue import study_catalogue
from fmuid.discrepancy.coupling import COUPLING_CHI2, FINEST, at_step, settle_step, step_scale
from fmuid.discrepancy.scan import Scanner, augmented
from fmuid.estimation.optimize import FitOptions, jacobian
from fmuid.estimation.study import make_problem

K, TAU1, TAU2, Q, SIGMA = 2.0, 0.4, 1.5, 0.15, 0.01
T = np.round(np.arange(0.0, 12.0 + 1e-9, 0.05), 10)
U = np.repeat(np.random.default_rng(3).uniform(0.2, 1.6, 6), 40)[: T.size]
U = np.concatenate([U, np.full(T.size - U.size, U[-1])])


def _levels(k: float, tau1: float, tau2: float, q: float) -> np.ndarray:
    """Both levels of the closed loop (the input linear between samples), solved by scipy."""

    def rhs(t: float, h: np.ndarray) -> list[float]:
        return [(k * np.interp(t, T, U) - h[0] - q * h[0] ** 2) / tau1, (h[0] - h[1]) / tau2]

    sol = solve_ivp(rhs, (T[0], T[-1]), [0.0, 0.0], t_eval=T, rtol=1e-10, atol=1e-12, max_step=0.01)
    return sol.y


def _reference_chi2(data: np.ndarray) -> float:
    """Chi2 of scipy's least-squares fit of K, tau1, tau2 and q to the data."""
    fit = least_squares(
        lambda p: ((data - _levels(*p)) / SIGMA).ravel(), [K, TAU1, TAU2, Q], x_scale="jac"
    )
    return float(2 * fit.cost)


@pytest.mark.slow
def test_a_coarse_coupling_is_refined_until_the_fit_reaches_scipys(two_tanks_fmu: Path) -> None:
    data = _levels(K, TAU1, TAU2, Q) + np.random.default_rng(4).normal(0, SIGMA, (2, T.size))
    record = experiment_from_arrays("est.csv", T, {"u": U, "h1": data[0], "h2": data[1]})
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {
                    "K": {"start": K, "lower": 0.1, "upper": 10.0},
                    "tau1": {"start": TAU1, "lower": 0.05, "upper": 0.9},
                    "tau2": {"start": TAU2, "lower": 1.0, "upper": 5.0},
                },
                "outputs": {"h1": {"sigma": SIGMA}, "h2": {"sigma": SIGMA}},
                "global_search": False,
            }
        )
    )
    base = augmented(make_problem(two_tanks_fmu, [record], spec), [])
    truth = {"K": K, "tau1": TAU1, "tau2": TAU2}
    z = base.to_z(truth)
    scanner = Scanner(base, z, jacobian(base, z))
    (quadratic,) = [c for c in study_catalogue(base, truth) if "c2_h1_u" in c.names]
    options = FitOptions()
    coarse = scanner.fit(scanner.screen(quadratic), options)
    settled = settle_step(scanner, coarse, options)
    reference = _reference_chi2(data)
    assert coarse.chi2 - reference > 4 * COUPLING_CHI2, "the default step must matter here"
    assert step_scale(settled.problem) < 1.0
    assert abs(settled.chi2 - reference) < 2 * COUPLING_CHI2
    assert settled.values["c2_h1_u"] == pytest.approx(-Q / K, rel=0.05)
    finest = replace(coarse, problem=at_step(coarse.problem, FINEST))
    assert settle_step(scanner, finest, options) is finest  # the bound holds across steps
