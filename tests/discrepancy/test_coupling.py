"""The fine step of a feedback term is refined until chi2 no longer feels it, against scipy.

A two-tank FMU (pythonfmu, no input derivatives: its feedback coupling holds the extrapolated
midpoint value over each step) misses a quadratic outflow of the upper tank,
``tau1 h1' = K u - h1 - q h1^2``. The feedback candidate ``c2_h1_u`` (``-q/K`` times ``h1^2``
added to ``u``) is the exact augmentation. The reference is scipy's least-squares fit of that
closed-loop equation, solved by ``solve_ivp``: an augmented fit on a fine enough step must reach
its chi2.
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
from fmuid.discrepancy.coupling import (
    COUPLING_CHI2,
    FINEST,
    at_step,
    dispersion,
    settle_step,
    step_scale,
)
from fmuid.discrepancy.scan import CandidateFit, Scanner, augmented
from fmuid.estimation.optimize import FitOptions, jacobian
from fmuid.estimation.study import make_problem

K, TAU1, TAU2, SIGMA = 2.0, 0.4, 1.5, 0.01


class Case:
    """Levels sampled every ``dt`` seconds under six random input plateaus of 2 s each."""

    def __init__(self, dt: float, q: float) -> None:
        self.q = q
        self.t = np.round(np.arange(0.0, 12.0 + 1e-9, dt), 10)
        plateaus = np.repeat(np.random.default_rng(3).uniform(0.2, 1.6, 6), round(2.0 / dt))
        self.u = np.append(plateaus, plateaus[-1])
        noise = np.random.default_rng(4).normal(0, SIGMA, (2, self.t.size))
        self.data = self.levels(K, TAU1, TAU2, q) + noise

    def levels(self, k: float, tau1: float, tau2: float, q: float) -> np.ndarray:
        """Both levels of the closed loop (the input linear between samples), solved by scipy."""

        def rhs(t: float, h: np.ndarray) -> list[float]:
            u = np.interp(t, self.t, self.u)
            return [(k * u - h[0] - q * h[0] ** 2) / tau1, (h[0] - h[1]) / tau2]

        span = (self.t[0], self.t[-1])
        sol = solve_ivp(rhs, span, [0.0, 0.0], t_eval=self.t, rtol=1e-10, atol=1e-12, max_step=0.01)
        return sol.y

    def reference_chi2(self) -> float:
        """Chi2 of scipy's least-squares fit of K, tau1, tau2 and q to the data."""
        fit = least_squares(
            lambda p: ((self.data - self.levels(*p)) / SIGMA).ravel(),
            [K, TAU1, TAU2, self.q],
            x_scale="jac",
        )
        return float(2 * fit.cost)

    def fit(self, fmu: Path, scale: float, sigma: float = SIGMA) -> tuple[Scanner, CandidateFit]:
        """The quadratic feedback fitted with the fine step ``scale`` times the default one."""
        record = experiment_from_arrays(
            "est.csv", self.t, {"u": self.u, "h1": self.data[0], "h2": self.data[1]}
        )
        spec = spec_from_json(
            json.dumps(
                {
                    "parameters": {
                        "K": {"start": K, "lower": 0.1, "upper": 10.0},
                        "tau1": {"start": TAU1, "lower": 0.05, "upper": 0.9},
                        "tau2": {"start": TAU2, "lower": 1.0, "upper": 5.0},
                    },
                    "outputs": {"h1": {"sigma": sigma}, "h2": {"sigma": sigma}},
                    "global_search": False,
                }
            )
        )
        base = at_step(augmented(make_problem(fmu, [record], spec), []), scale)
        truth = {"K": K, "tau1": TAU1, "tau2": TAU2}
        z = base.to_z(truth)
        scanner = Scanner(base, z, jacobian(base, z))
        (quadratic,) = [c for c in study_catalogue(base, truth) if "c2_h1_u" in c.names]
        return scanner, scanner.fit(scanner.screen(quadratic), FitOptions())


@pytest.mark.slow
def test_the_midpoint_coupling_reaches_scipys_fit_at_the_default_step(two_tanks_fmu: Path) -> None:
    case = Case(dt=0.05, q=0.15)
    scanner, fit = case.fit(two_tanks_fmu, 1.0)
    assert abs(fit.chi2 - case.reference_chi2()) < COUPLING_CHI2
    assert fit.values["c2_h1_u"] == pytest.approx(-case.q / K, rel=0.02)
    assert settle_step(scanner, fit, FitOptions()) is fit


@pytest.mark.slow
def test_a_coarse_coupling_is_refined_until_the_fit_reaches_scipys(two_tanks_fmu: Path) -> None:
    case = Case(dt=0.2, q=1.0)
    scanner, coarse = case.fit(two_tanks_fmu, 4.0)
    options = FitOptions()
    settled = settle_step(scanner, coarse, options)
    reference = case.reference_chi2()
    assert coarse.chi2 - reference > 4 * COUPLING_CHI2, "one step per sample must matter here"
    assert step_scale(settled.problem) < 4.0
    assert abs(settled.chi2 - reference) < 2 * COUPLING_CHI2
    assert settled.values["c2_h1_u"] == pytest.approx(-case.q / K, rel=0.02)
    finest = replace(coarse, problem=at_step(coarse.problem, FINEST))
    assert settle_step(scanner, finest, options) is finest  # the bound holds across steps


@pytest.mark.slow
def test_the_step_kept_does_not_depend_on_the_scale_of_the_sigmas(two_tanks_fmu: Path) -> None:
    """Sigmas 10x too small (a textbook model's misfit): chi2 is read in units of the dispersion."""
    case = Case(dt=0.2, q=1.0)
    options = FitOptions()
    right = settle_step(*case.fit(two_tanks_fmu, 4.0), options)
    scanner, coarse = case.fit(two_tanks_fmu, 4.0, sigma=SIGMA / 10)
    small = settle_step(scanner, coarse, options)
    assert dispersion(small) > 50
    assert step_scale(small.problem) == step_scale(right.problem) < 4.0
    assert small.values["c2_h1_u"] == pytest.approx(right.values["c2_h1_u"], rel=1e-3)
