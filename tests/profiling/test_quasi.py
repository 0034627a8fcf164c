"""Cheap walk re-fits and valley-switch detection, against closed forms and scipy."""

from types import SimpleNamespace

import numpy as np
from scipy.optimize import least_squares

from fmuid.profiling.checks import switches
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.quasi import Secant, quasi_refit
from fmuid.profiling.walk import path_tangent


def _problem(residuals, n):
    return SimpleNamespace(
        residuals=residuals, z_lower=np.full(n, -10.0), z_upper=np.full(n, 10.0), n_free=n
    )


def test_gauss_newton_on_a_carried_jacobian_matches_scipy():
    """A nonlinear model, parameter 0 held off its optimum, a warm start near the re-fit and
    the Jacobian of the all-free optimum: the cheap re-fit lands on scipy's re-fit."""
    t = np.linspace(0.0, 1.0, 40)
    y = 1.5 * np.exp(-0.7 * t) + 0.3 * t

    def residuals(z):
        return z[0] * np.exp(-z[1] * t) + z[2] * t - y

    ref = least_squares(
        lambda x: residuals(np.r_[1.45, x]), [0.7, 0.3], xtol=1e-15, ftol=1e-15, gtol=1e-15
    )
    jac = np.column_stack([np.exp(-0.7 * t), -1.5 * t * np.exp(-0.7 * t), t])
    z0 = np.r_[1.45, ref.x + [0.02, -0.01]]
    free = np.array([False, True, True])
    z, chi2, settled = quasi_refit(_problem(residuals, 3), z0, free, Secant(jac, z0), 1e-10)
    assert settled
    assert 0.0 <= chi2 - 2.0 * ref.cost < 1e-9
    assert np.allclose(z[1:], ref.x, atol=1e-4)


def test_a_bound_the_step_pushes_against_is_held():
    """The unconstrained optimum of parameter 1 lies below its bound: it stays on the bound."""
    t = np.linspace(0.0, 1.0, 20)

    def residuals(z):
        return z[0] + z[1] * t - (1.0 - 2.0 * t)

    problem = SimpleNamespace(
        residuals=residuals,
        z_lower=np.array([-10.0, 0.0]),
        z_upper=np.array([10.0, 10.0]),
        n_free=2,
    )
    jac = np.column_stack([np.ones_like(t), t])
    z, chi2, settled = quasi_refit(
        problem, np.array([0.5, 1.0]), np.ones(2, bool), Secant(jac, np.zeros(2)), 1e-12
    )
    ref = least_squares(residuals, [0.5, 1.0], bounds=([-10.0, 0.0], [10.0, 10.0]), xtol=1e-14)
    assert settled
    assert np.allclose(z, ref.x, atol=1e-8)
    assert abs(chi2 - 2.0 * ref.cost) < 1e-9


def test_the_tangent_is_the_conditional_mean_direction():
    """For a linear model the profile path is exactly linear along C[:, i] / C[i, i]."""
    rng = np.random.default_rng(3)
    jac = rng.normal(size=(30, 3))
    tangent = path_tangent(jac, 0)
    others = np.linalg.lstsq(jac[:, 1:], -jac[:, 0], rcond=None)[0]
    assert tangent[0] == 1.0
    assert np.allclose(tangent[1:], others)


def _path(values):
    return [WalkPoint(np.array(v, dtype=float), 0.0) for v in values]


def test_a_smooth_path_has_no_switch_and_a_jump_of_the_others_is_one():
    """Curved but smooth nuisance paths pass; a jump of another parameter is found."""
    lower, upper = np.zeros(3), np.ones(3)
    s = np.linspace(0.5, 0.8, 7)
    smooth = _path([[x, 0.2 + 0.5 * (x - 0.5) ** 2, 0.6 - 0.3 * (x - 0.5)] for x in s])
    assert switches(smooth, 0, lower, upper) == []
    jumped = [list(p.z) for p in smooth]
    for k in range(4, 7):
        jumped[k][1] += 0.4
    assert switches(_path(jumped), 0, lower, upper) == [4]
