"""Cheap re-fits along a walk: Gauss-Newton steps on a Jacobian carried from point to point.

A trust-region re-fit (:func:`fmuid.estimation.optimize.refine`) spends a finite-difference
Jacobian (one run per free parameter) on every iteration and one more at its final point: 12 to
30 runs of a 5-parameter problem per profile point, however good its start. Along a walk the
Jacobian changes little from one point to the next, so the walk carries one (the fit's at the
estimate) and corrects it with Broyden's rank-one update from every run it makes: a point then
costs its Gauss-Newton steps, one run each, two to four from a good start. The walk's points are
real chi2 values at feasible parameters (never below the profile); the crossings are still
located by full re-fits (:mod:`fmuid.profiling.ends`). When the steps stop descending or do not
settle, the caller re-fits fully from the lowest point they reached.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fmuid.errors import FmuError
from fmuid.estimation.problem import Problem

#: Steps of one cheap re-fit before it gives up (the caller then re-fits fully).
MAX_STEPS = 6
#: Directions of the Jacobian weaker than this fraction of its strongest are left out of a
#: step (a flat valley's direction would otherwise take the step far off).
RCOND = 1e-6
#: A step on a renewed Jacobian that lowers chi2 by less than this fraction of the decrease it
#: predicted shows a strongly nonlinear valley: the trust-region re-fit takes over at once.
POOR = 0.25


@dataclass
class Secant:
    """The Jacobian carried along a walk and the last point it was corrected at.

    Attributes
    ----------
    jac
        Weighted residual Jacobian, all free parameters, fitted coordinates.
    z, r
        The last point run and its residuals (``r`` is ``None`` before the first run).

    """

    jac: np.ndarray
    z: np.ndarray
    r: np.ndarray | None = None

    def update(self, z: np.ndarray, r: np.ndarray) -> None:
        """Broyden's rank-one correction from the run at ``z``; ``z`` becomes the last point."""
        if self.r is not None:
            dz = z - self.z
            norm = float(dz @ dz)
            if norm > 0.0:
                self.jac = self.jac + np.outer(r - self.r - self.jac @ dz, dz) / norm
        self.z, self.r = z.copy(), r.copy()

    def refresh(self, jac: np.ndarray) -> None:
        """Replace the Jacobian by a freshly computed one."""
        self.jac = jac


def quasi_refit(
    problem: Problem,
    guess: np.ndarray,
    free: np.ndarray,
    secant: Secant,
    tolerance: float,
    diff_step: float = 1e-6,
    fresh: bool = False,
) -> tuple[np.ndarray, float, bool] | None:
    """Re-fit the ``free`` parameters from ``guess`` by Gauss-Newton steps on ``secant``.

    Each step is the least-squares step of the carried Jacobian, kept within the bounds and
    halved once when chi2 does not fall; every run corrects the Jacobian. A step that still
    does not descend renews the free columns by forward differences (relative step
    ``diff_step``) once (``fresh``: at ``guess``, before the first step, and not again). It
    stops when the chi2 decrease the next step predicts is below ``tolerance``, and gives up
    when a step on a renewed Jacobian achieves less than ``POOR`` of its predicted decrease.
    A ``guess`` equal to the secant's last point reuses its residuals.

    Returns
    -------
    tuple or None
        The lowest point reached, its chi2 and whether it settled (``False`` when a step does
        not descend on a renewed Jacobian either or ``MAX_STEPS`` steps do not settle: re-fit
        fully from there); ``None`` when a simulation fails.

    """
    lo, hi = problem.z_lower, problem.z_upper
    z = np.clip(np.asarray(guess, dtype=float), lo, hi)
    try:
        if secant.r is not None and np.array_equal(z, secant.z):
            r = secant.r.copy()
        else:
            r = problem.residuals(z)
            secant.update(z, r)
        chi2 = float(r @ r)
        renewed = fresh
        if fresh:
            _renew(problem, z, r, free, secant, diff_step)
        for _ in range(MAX_STEPS):
            step, predicted = _step(secant.jac, r, z, free, lo, hi)
            if predicted < tolerance:
                return z, chi2, True
            for shrink in (1.0, 0.5):
                trial = np.clip(z + shrink * step, lo, hi)
                r_new = problem.residuals(trial)
                secant.update(trial, r_new)
                if float(r_new @ r_new) < chi2:
                    poor = renewed and chi2 - float(r_new @ r_new) < POOR * shrink * predicted
                    z, r, chi2 = trial, r_new, float(r_new @ r_new)
                    if poor:
                        return z, chi2, False
                    break
            else:
                if renewed:
                    return z, chi2, False
                _renew(problem, z, r, free, secant, diff_step)
                renewed = True
    except FmuError:
        return None
    return z, chi2, False


def _step(
    jac: np.ndarray, r: np.ndarray, z: np.ndarray, free: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, float]:
    """Return the Gauss-Newton step of the free parameters and the chi2 decrease it predicts.

    A parameter on a bound that the step would push outwards is held there (active set).
    """
    edge = 1e-8 * (hi - lo)
    active = free.copy()
    step = np.zeros_like(z)
    while active.any():
        step = np.zeros_like(z)
        step[active] = np.linalg.lstsq(jac[:, active], -r, rcond=RCOND)[0]
        out = active & (((z <= lo + edge) & (step < 0)) | ((z >= hi - edge) & (step > 0)))
        if not out.any():
            break
        active &= ~out
    else:
        return step, 0.0
    return step, float(r @ r) - float(np.sum((r + jac @ step) ** 2))


def _renew(
    problem: Problem,
    z: np.ndarray,
    r: np.ndarray,
    free: np.ndarray,
    secant: Secant,
    diff_step: float,
) -> None:
    """Renew the free columns of the Jacobian at ``z`` by forward differences."""
    jac = secant.jac.copy()
    for j in np.flatnonzero(free):
        h = diff_step * max(1.0, abs(float(z[j])))
        h = h if z[j] + h <= problem.z_upper[j] else -h
        moved = z.copy()
        moved[j] += h
        jac[:, j] = (problem.residuals(moved) - r) / h
    secant.refresh(jac)
    secant.z, secant.r = z.copy(), r.copy()
