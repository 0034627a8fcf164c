"""Residual tests against their null distributions and against planted structure."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from fmuid.discrepancy import residual_tests as rt
from fmuid.discrepancy.lag import first_order_lag


def _series(r: np.ndarray, dt: float = 0.2, seed: int = 0) -> rt.Series:
    t = np.arange(len(r)) * dt
    u = np.deg2rad(5) * np.sin(2 * np.pi * (0.1 * t + 0.01 * t**2))
    return rt.Series("chirp.csv", "gam_t", t, r, {"delta": u})


def test_false_alarm_rate_of_the_family_is_at_most_the_design_level() -> None:
    rng = np.random.default_rng(0)
    alarms = 0
    trials = 300
    for _ in range(trials):
        family = [_series(rng.normal(size=150)), _series(rng.normal(size=100))]
        tests = rt.series_tests(family, sigma_known=True)
        alarms += bool(rt.holm(tests))
    # binomial(300, 0.01): P(X >= 9) < 0.5%; Holm is conservative under dependence
    assert alarms / trials <= 0.03


def test_whiteness_of_fitted_residuals_is_calibrated_on_their_own_null() -> None:
    # 101 samples less what 6 smooth sensitivities absorb: the fit correlates neighbours
    rng = np.random.default_rng(0)
    n, t = 101, np.linspace(0.0, 1.0, 101)
    sines = np.sin(2 * np.pi * np.outer(t, [0.3, 0.7, 1.1, 1.9, 2.5, 3.3]) + rng.uniform(0, 6, 6))
    basis = np.linalg.qr(sines)[0]

    def fitted(draws: int) -> np.ndarray:
        e = rng.standard_normal((draws, n))
        return e - (e @ basis) @ basis.T

    lags = rt.lb_lags(n)
    null = rt.ljung_box_null(fitted(400), lags)
    residuals = fitted(4000)
    calibrated, _ = rt.whiteness_p(rt.ljung_box_null(residuals, lags), lags, null)
    asymptotic, _ = rt.whiteness_p(rt.ljung_box_null(residuals, 20), 20)
    # binomial(4000, 0.05): 0.03 and 0.07 are 5.8 sd away
    assert 0.03 <= np.mean(calibrated < 0.05) <= 0.07
    assert np.mean(asymptotic < 0.05) > 0.1  # chi2(20) at n // 5 lags: the test it replaces
    one = rt.ljung_box(rt.Series("e", "y", t, residuals[0]), null=null)
    assert one.p_value == calibrated[0]


def test_whiteness_and_windows_and_spectrum_find_planted_structure() -> None:
    rng = np.random.default_rng(1)
    n = 150
    t = np.arange(n) * 0.2
    bump = 2.5 * np.exp(-0.5 * ((t - 12.0) / 1.5) ** 2)
    wave = 0.8 * np.sin(2 * np.pi * 0.6 * t)
    s = _series(rng.normal(size=n) + bump)
    assert rt.ljung_box(s).p_value < 1e-3
    found = rt.windows(s)
    assert found and any(w.start <= 12.0 <= w.end for w in found)
    band = rt.spectrum_band(_series(rng.normal(size=n) + wave))
    assert band is not None and band[0] <= 0.6 <= band[1]


def test_input_cross_correlation_detects_an_input_driven_error() -> None:
    rng = np.random.default_rng(2)
    clean = _series(rng.normal(size=150))
    driven = rt.Series(
        clean.experiment,
        clean.output,
        clean.time,
        clean.residuals + 60 * np.roll(clean.inputs["delta"], 3),
        clean.inputs,
    )
    assert rt.input_cross_correlation(driven)[0].p_value < 1e-6


def test_first_order_lag_is_exact_for_piecewise_linear_input() -> None:
    t = np.array([0.0, 0.3, 0.35, 1.0, 1.7, 2.5])
    u = np.array([0.0, 1.0, -0.5, 0.2, 0.2, 2.0])
    tau = 0.17
    sol = solve_ivp(
        lambda s, y: (np.interp(s, t, u) - y) / tau,
        (0, 2.5),
        [0.0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-13,
        max_step=0.01,
    )
    np.testing.assert_allclose(first_order_lag(t, u, tau), sol.y[0], atol=1e-8)
    grid = np.linspace(0, 2.5, 126)
    ug = np.interp(grid, t, u)
    sol = solve_ivp(
        lambda s, y: (np.interp(s, grid, ug) - y) / tau,
        (0, 2.5),
        [0.0],
        t_eval=grid,
        rtol=1e-11,
        atol=1e-13,
        max_step=0.005,
    )
    np.testing.assert_allclose(first_order_lag(grid, ug, tau), sol.y[0], atol=1e-8)


def test_input_cross_correlation_on_a_record_shorter_than_its_longest_lag() -> None:
    """A 1 s record at 1 kHz: lags stay within a fifth of it (the 2 s default once crashed)."""
    rng = np.random.default_rng(4)
    t = np.arange(1001) * 1e-3
    u = np.sin(2 * np.pi * 5 * t)
    shift = 20  # 20 ms, inside a fifth of the record
    r = rng.normal(size=t.size) + 5 * np.concatenate([np.zeros(shift), u[:-shift]])
    series = rt.Series("short.csv", "y", t, r, {"u": u})
    assert rt.input_cross_correlation(series)[0].p_value < 1e-6
    assert rt.lagged(np.arange(3.0), [0, 5]).tolist() == [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]
