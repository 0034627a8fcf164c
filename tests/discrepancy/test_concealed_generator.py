"""The concealed-case generator makes what it promises, re-checked by independent computations.

The re-check does not reuse ``testbed/operational.py``: the Ljung-Box statistic comes from
``numpy.correlate``, the augmentation is fitted through ``fmuid.fit`` with a predictor whose lag
is integrated by ``scipy.signal.lsim``, and the base fit is redone from the true tires.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pytest
from scipy import signal, stats

import concealed as cc
import fieldtruth as ft
import operational as op
from fmuid.data import Experiment, ParameterSpec
from fmuid.estimation.optimize import fit_problem
from fmuid.estimation.problem import Problem
from fmuid.model.registry import get_simulator


def ljung_box_p(x: np.ndarray) -> float:
    x = x - x.mean()
    n = len(x)
    h = min(20, n // 5)
    acf = np.correlate(x, x, mode="full")[n : n + h] / np.correlate(x, x)[0]
    q = n * (n + 2) * sum(acf[k - 1] ** 2 / (n - k) for k in range(1, h + 1))
    return float(stats.chi2.sf(q, h))


class WrappedFmu:
    """The FMU with a first-order output lag (``tau``) or a steer offset (``offset``)."""

    def __init__(self, fmu: Path, added: str) -> None:
        self.fmu, self.added = fmu, added

    def predict(
        self, params: Mapping[str, float], experiment: Experiment, outputs: Sequence[str]
    ) -> np.ndarray:
        values = dict(params)
        extra = values.pop(self.added)
        t_in, u_in = experiment.input_samples("delta")
        sim = get_simulator(self.fmu)
        if self.added == "offset":
            return sim.simulate(values, t_in, {"delta": u_in + extra}, experiment.time, outputs)
        fine = np.round(np.arange(0.0, experiment.time[-1] + 1e-9, 0.01), 6)  # lsim: uniform
        y = sim.simulate(values, t_in, {"delta": u_in}, fine, outputs)
        lag = ([[-1.0 / extra]], [[1.0 / extra]], [[1.0]], [[0.0]])
        cols = [signal.lsim(lag, y[:, j], fine, X0=[y[0, j]])[1] for j in range(len(outputs))]
        return np.column_stack([np.interp(experiment.time, fine, c) for c in cols])


def recheck(tractor_fmu: Path, made: cc.ConcealedCase, added: str, bounds: tuple[float, float]):
    case = made.case
    spec = op.study_spec()
    tires = {n: case.truth[n] for n in ft.BOUNDS}
    base = Problem(tractor_fmu, case.experiments, spec)
    fit = fit_problem(base, start=made.check["base"], global_search=False)
    fit_truth = fit_problem(base, start=tires, global_search=False)
    fit = min(fit, fit_truth, key=lambda f: f.chi2)
    r = base.residuals(base.to_z(fit.estimates))
    splits = np.cumsum([int(m.sum()) for ms in base.masks for m in ms])[:-1]
    dof = base.n_data - base.n_free
    lo, hi = stats.chi2.interval(0.95, dof)
    params = dict(spec.parameters)
    params[added] = ParameterSpec(
        start=case.magnitude, lower=bounds[0], upper=bounds[1], scale="lin"
    )
    wrapped = Problem(
        tractor_fmu,
        case.experiments,
        spec,
        predictor=WrappedFmu(tractor_fmu, added),
        parameters=params,
    )
    aug = fit_problem(wrapped, start={**fit.estimates, added: case.magnitude}, global_search=False)
    return [ljung_box_p(part) for part in np.split(r, splits)], fit.chi2, (lo, hi), aug


@pytest.mark.slow
@pytest.mark.parametrize(
    ("effect", "added", "bounds"),
    [("output_lag", "tau", (1e-4, 1.0)), ("input_offset", "offset", (-0.05, 0.05))],
)
def test_concealed_case_meets_the_criteria(
    tractor_fmu: Path, effect: str, added: str, bounds: tuple[float, float]
) -> None:
    made = cc.concealed_case(effect, seed=5)
    assert made.concealed, made.check["failures"]
    assert cc.LAMBDA_RANGE[0] / 1.2 < made.achieved_lambda < cc.LAMBDA_RANGE[1] * 1.2
    whiteness, chi2, (lo, hi), aug = recheck(tractor_fmu, made, added, bounds)
    assert len(whiteness) == 4
    assert min(whiteness) > 0.05
    assert lo < chi2 < hi
    assert chi2 == pytest.approx(made.check["chi2_base"], abs=0.1)
    p = stats.chi2.sf(chi2 - aug.chi2, 1)
    assert 1e-12 <= p <= 1e-3
    assert aug.estimates[added] == pytest.approx(made.check["magnitude_fit"], rel=0.05)


def test_first_order_lag_matches_lsim() -> None:
    t = np.linspace(0.0, 3.0, 31)
    y = np.sin(2.0 * t) + (t > 1.0) * (t - 1.0)
    lag = ([[-1.0 / 0.3]], [[1.0 / 0.3]], [[1.0]], [[0.0]])
    expected = signal.lsim(lag, y, t, X0=[y[0]])[1]
    np.testing.assert_allclose(op.first_order_lag(t, y, 0.3), expected, atol=1e-9)


def test_ljung_box_matches_an_independent_sum() -> None:
    rng = np.random.default_rng(3)
    for x in (rng.normal(size=150), np.cumsum(rng.normal(size=101))):
        assert op.ljung_box(x) == pytest.approx(ljung_box_p(x), rel=1e-9, abs=1e-300)


def test_the_same_seed_draws_the_same_case_and_effects_draw_apart() -> None:
    a, b = cc.draw_design("input_offset", 4), cc.draw_design("input_offset", 4)
    assert a.truth == b.truth and a.target_lambda == b.target_lambda
    assert cc.draw_design("output_lag", 4).truth != a.truth
    assert cc.LAMBDA_RANGE[0] <= a.target_lambda <= cc.LAMBDA_RANGE[1]
    for _, _, _, t_out, sigma, snr in a.runs:
        assert 25.0 <= snr <= 100.0 and sigma > 0
        assert np.diff(t_out)[0] in (pytest.approx(0.1), pytest.approx(0.2))
