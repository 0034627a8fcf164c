"""The generic error-model test: closed forms, its null distribution, and its power.

The data come from an independent scipy solution of the mass-spring-damper (and, for the
power, of the same mass with an absorber mass hung on it that the FMU does not have).
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import integrate, stats

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.discrepancy import decide, generic
from fmuid.estimation.optimize import fit_problem, safe_residuals
from fmuid.estimation.problem import Problem
from fmuid.stages import make_problem

TRUE = {"m": 1.1, "k": 4.4, "b": 1.6}
SIGMA = 0.02
TIMES = np.arange(0.0, 20.0 + 1e-9, 0.1)
FORCE = (TIMES, 4.0 * np.sin(2 * np.pi * (0.05 + 0.02 * TIMES) * TIMES))


def test_laguerre_step_responses_match_their_closed_forms() -> None:
    pole_hz = 0.3
    p = 2 * np.pi * pole_hz
    t = np.linspace(0.0, 10.0, 401)
    y = generic.laguerre(pole_hz, t, np.ones_like(t))
    first = np.sqrt(2 * p) / p * (1 - np.exp(-p * t))
    second = np.sqrt(2 * p) * ((1 - np.exp(-p * t)) / p - 2 * t * np.exp(-p * t))
    np.testing.assert_allclose(y[:, 0], first, atol=1e-9)
    np.testing.assert_allclose(y[:, 1], second, atol=1e-9)


def _data(seed: int, absorber: float) -> object:
    """Position and velocity of the mass; ``absorber`` kg hung on it by a spring and damper."""
    k2, b2 = 2.0, 0.3

    def rhs(t: float, s: np.ndarray) -> list[float]:
        x, v, x2, v2 = s
        coupling = k2 * (x2 - x) + b2 * (v2 - v) if absorber > 0 else 0.0
        f = np.interp(t, *FORCE)
        a = (f - TRUE["b"] * v - TRUE["k"] * x + coupling) / TRUE["m"]
        return [v, a, v2, -coupling / absorber if absorber > 0 else 0.0]

    sol = integrate.solve_ivp(
        rhs, (0.0, TIMES[-1]), [0.0] * 4, t_eval=TIMES, rtol=1e-10, atol=1e-12, max_step=0.02
    )
    noise = np.random.default_rng(seed).normal(0.0, SIGMA, (2, TIMES.size))
    columns = {"f": FORCE[1], "x": sol.y[0] + noise[0], "v": sol.y[1] + noise[1]}
    return experiment_from_arrays("chirp.csv", TIMES, columns)


def _problem(msd_fmu: Path, data: object, lower: float, upper: float) -> Problem:
    """The msd study of ``data``: m, k, b free within ``[lower, upper]``, started at the truth."""
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {
                    n: {"start": v, "lower": lower, "upper": upper} for n, v in TRUE.items()
                },
                "inputs": ["f"],
                "outputs": {"x": {"sigma": SIGMA}, "v": {"sigma": SIGMA}},
                "global_search": False,
            }
        )
    )
    return make_problem(msd_fmu, [data], spec)  # type: ignore[list-item]


def _generic_p(msd_fmu: Path, seed: int, absorber: float) -> float:
    problem = _problem(msd_fmu, _data(seed, absorber), 0.05, 20.0)
    fit = fit_problem(problem, global_search=False, seed=0)
    z = fit.z_estimate()
    model = generic.local_model(problem, z, fit.jacobian)
    test, _ = generic.generic_test(problem, safe_residuals(problem, z), model, seed)
    assert test is not None and test.test == generic.NAME
    return test.p_value


@pytest.mark.slow
def test_the_test_holds_its_level_on_the_right_model(msd_fmu: Path) -> None:
    p = np.array([_generic_p(msd_fmu, seed, 0.0) for seed in range(60)])
    assert stats.kstest(p, "uniform").pvalue > 1e-3
    assert np.mean(p < 0.05) <= 0.05 + 3 * np.sqrt(0.05 * 0.95 / len(p))


def test_an_unmodelled_absorber_mass_is_found(msd_fmu: Path) -> None:
    assert _generic_p(msd_fmu, 1, 0.15) < 1e-6


def test_misfit_that_wants_a_pinned_parameter_beyond_its_bound_counts() -> None:
    # e1: the sensitivity of a parameter at its bound, signed inward; phi: (e1 + e2) / sqrt 2.
    e = np.eye(6)
    pinned, phi = e[:, :1], ((e[:, 0] + e[:, 1]) / np.sqrt(2))[:, None]
    outward = -3.0 * e[:, 0] + 2.0 * e[:, 2]
    # null: d = 0, chi2 13; with phi: min (3 + x)^2 + x^2 + 4 at x = -1.5 is 8.5
    assert generic.constrained_drop(outward, phi, pinned) == pytest.approx(4.5, abs=1e-9)
    # inward, a move of the parameter takes the e1 part in both fits
    inward = 3.0 * e[:, 0] + 2.0 * e[:, 2]
    assert generic.constrained_drop(inward, phi, pinned) == pytest.approx(0.0, abs=1e-9)


def test_the_local_model_pins_parameters_at_a_bound_signed_inward(msd_fmu: Path) -> None:
    problem = _problem(msd_fmu, _data(0, 0.0), 0.5, 5.0)
    z = problem.to_z({"m": 0.5, "k": 5.0, "b": 1.6})
    jac = np.random.default_rng(0).normal(size=(10, 3))
    basis, pinned = generic.local_model(problem, z, jac)
    k = {n: i for i, n in enumerate(problem.names)}
    np.testing.assert_allclose(pinned, np.column_stack([jac[:, k["m"]], -jac[:, k["k"]]]))
    assert basis.shape == (10, 1)
    np.testing.assert_allclose(abs(basis[:, 0] @ jac[:, k["b"]]), np.linalg.norm(jac[:, k["b"]]))


def test_the_fit_with_the_error_model_keeps_a_pinned_parameter_inside() -> None:
    e = np.eye(6)
    pinned, phi = e[:, :1], ((e[:, 0] + e[:, 1]) / np.sqrt(2))[:, None]
    block = generic.Block(0.1, phi, 0.0, 1.0)
    fitted = generic.fitted_residuals(-3.0 * e[:, 0] + 2.0 * e[:, 2], block, (e[:, 5:5], pinned))
    # the minimum of the closed form above: (3 + x)^2 + x^2 + 4 at x = -1.5
    np.testing.assert_allclose(fitted, [-1.5, 1.5, 2.0, 0.0, 0.0, 0.0], atol=1e-9)


def test_the_error_model_ties_a_candidate_only_when_it_fits_as_well() -> None:
    noise = np.random.default_rng(0).standard_normal(1000)
    best = SimpleNamespace(residuals=noise, problem=SimpleNamespace(n_free=7))
    worse = noise + 0.3  # chi2 up by about 90
    assert decide.generic_tie(best, worse, 10, "m") is None  # type: ignore[arg-type]
    tie = decide.generic_tie(best, noise.copy(), 10, "m")  # type: ignore[arg-type]
    assert tie is not None and tie["effect"] == "unexplained" and tie["p_value"] >= 0.05
