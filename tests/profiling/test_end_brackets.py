"""CI ends bracketed across a switch of valley or by a stale re-fit, against scipy re-fits."""

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from scipy.optimize import least_squares

from fmuid.estimation.optimize import FitOptions
from fmuid.profiling.ends import Located, locate
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.walk import path_tangent

sys.path.insert(0, str(Path(__file__).parent))
from reference import ReferenceProfile  # noqa: E402


def _residuals(z: np.ndarray) -> np.ndarray:
    """Two valleys of ``z1`` for each ``z0``: A at ``z1 = 1`` (chi2 ``9 z0^2``, the estimate's)
    and B at ``z1 = -1`` (chi2 ``(2 + 0.1 z0)^2``: lower than A beyond ``z0 = 0.69``). The
    ridge between them lies at ``z1 = 0.59``: a start blended between the valleys re-fits into B.
    """
    w = 2.0 * ((z[1] + 1.0) / 2.0) ** 3 - 1.0
    mix = (w + 1.0) / 2.0
    return np.array([10.0 * (w * w - 1.0), mix * 3.0 * z[0] + (1.0 - mix) * (2.0 + 0.1 * z[0])])


def _problem() -> SimpleNamespace:
    return SimpleNamespace(
        residuals=_residuals,
        z_lower=np.array([-5.0, -3.0]),
        z_upper=np.array([5.0, 3.0]),
        n_free=2,
        n_data=2,
    )


def _fit(problem: SimpleNamespace, z0: np.ndarray) -> WalkPoint:
    res = least_squares(lambda x: problem.residuals(np.r_[z0[0], x]), z0[1:], xtol=1e-14)
    return WalkPoint(np.r_[z0[0], res.x], 2.0 * res.cost)


def test_an_end_bracketed_across_a_valley_switch_is_the_lower_valleys_crossing():
    """The walk met valley B at ``z0 = 1`` (as after a re-walk from a lower valley): the end of
    threshold 1 lies in valley A at ``z0 = 1/3``, not at the estimate."""
    problem = _problem()
    estimate = _fit(problem, np.array([0.0, 1.0]))
    outer = _fit(problem, np.array([1.0, -1.0]))
    assert estimate.chi2 < 1e-12 and 4.0 < outer.chi2 < 5.0
    h = 1e-7
    jac = -np.column_stack(
        [(_residuals(estimate.z + h * e) - _residuals(estimate.z)) / h for e in np.eye(2)]
    )
    end = locate(
        problem,
        0,
        estimate.chi2,
        0.0,
        1.0,
        [estimate, outer],
        FitOptions(ftol=1e-10, xtol=1e-10, gtol=1e-10),
        tangent=path_tangent(jac, 0),
    )
    exact = ReferenceProfile(problem, 0, estimate.z).crossing(estimate.chi2, 1.0, 0.5)
    assert abs(exact - 1.0 / 3.0) < 1e-3
    assert end.settled
    assert abs(end.z - exact) < 0.01 * exact


def test_a_rise_read_on_a_stale_jacobian_is_confirmed_before_it_brackets_an_end():
    """A walk point whose carried-Jacobian re-fit read chi2 too high (1.3 where the profile is
    0.6, under the threshold 1) would bracket the end inside the profile; re-fitted afresh it
    does not, and the end is the crossing between it and the next point."""
    t = np.linspace(0.0, 1.0, 30)
    y = 1.5 * np.exp(-0.7 * t) + 0.3 * t + 0.05 * np.sin(17.0 * t)
    problem = SimpleNamespace(
        residuals=lambda z: (z[0] * np.exp(-z[1] * t) + z[2] * t - y) / 0.05,
        z_lower=np.full(3, -5.0),
        z_upper=np.full(3, 5.0),
        n_free=3,
        n_data=30,
    )
    full = least_squares(problem.residuals, [1.5, 0.7, 0.3], xtol=1e-14, ftol=1e-14)
    estimate = WalkPoint(full.x, 2.0 * full.cost)
    ref = ReferenceProfile(problem, 0, full.x)
    exact = ref.crossing(estimate.chi2, 1.0, full.x[0] + 0.05)

    def point(z0: float, chi2: float | None = None, carried: bool = False) -> WalkPoint:
        res = least_squares(lambda x: problem.residuals(np.r_[z0, x]), full.x[1:], xtol=1e-14)
        true = WalkPoint(np.r_[z0, res.x], 2.0 * res.cost)
        return WalkPoint(true.z, true.chi2 if chi2 is None else chi2, carried=carried)

    inner = full.x[0] + 0.8 * (exact - full.x[0])
    stale = point(inner, estimate.chi2 + 1.3, carried=True)
    assert point(inner).chi2 - estimate.chi2 < 0.7
    outer = point(full.x[0] + 1.6 * (exact - full.x[0]))
    end = locate(
        problem, 0, estimate.chi2, float(full.x[0]), 1.0, [estimate, stale, outer], FitOptions()
    )
    assert end.settled
    assert abs(end.z - exact) < 0.01 * abs(exact - full.x[0])


def test_a_bracket_located_once_is_not_located_again_after_the_side_grows():
    """``chi2 = 9 z0^2 + (z1 - z0)^2`` profiles to ``9 z0^2`` (the threshold 1 is crossed at
    ``z0 = 1/3``, closed form). Located twice with the same record, the second time with a
    point added beyond the bracket (as a re-walk adds points), the end runs no simulation and
    is the same."""
    calls = []

    def residuals(z: np.ndarray) -> np.ndarray:
        calls.append(1)
        return np.array([3.0 * z[0], z[1] - z[0]])

    problem = SimpleNamespace(
        residuals=residuals, z_lower=np.full(2, -5.0), z_upper=np.full(2, 5.0), n_free=2, n_data=2
    )
    side = [WalkPoint(np.array([0.0, 0.0]), 0.0), WalkPoint(np.array([0.5, 0.5]), 2.25)]
    located = Located()
    first = locate(problem, 0, 0.0, 0.0, 1.0, side, FitOptions(), located=located)
    assert calls and abs(first.z - 1.0 / 3.0) < 1e-3 / 3.0
    calls.clear()
    again = locate(
        problem,
        0,
        0.0,
        0.0,
        1.0,
        [*side, WalkPoint(np.array([0.8, 0.8]), 5.76)],
        FitOptions(),
        located=located,
    )
    assert not calls
    assert again.z == first.z
