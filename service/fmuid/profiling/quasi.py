"""Cheap re-fits along a walk: Gauss-Newton steps on a Jacobian carried from point to point.

A trust-region re-fit (:func:`fmuid.estimation.optimize.refine`) spends a finite-difference
Jacobian (one run per free parameter) on every iteration and one more at its final point: 12 to
30 runs of a 5-parameter problem per profile point, however good its start. Along a walk the
Jacobian changes little from one point to the next, so the walk carries one (the fit's at the
estimate) and corrects it with Broyden's rank-one update from every run it makes: a point then
costs its Gauss-Newton steps, one run each, two to four from a good start. The walk's points are
real chi2 values at feasible parameters (never below the profile); the crossings are still
located by full re-fits (:mod:`fmuid.profiling.ends`). When the steps stop descending or do not
settle, the caller falls back to the full re-fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fmuid.errors import FmuError
from fmuid.estimation.problem import Problem

#: Steps of one cheap re-fit before it gives up (the caller then re-fits fully).
MAX_STEPS = 6


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
) -> tuple[np.ndarray, float] | None:
    """Re-fit the ``free`` parameters from ``guess`` by Gauss-Newton steps on ``secant``.

    Each step is the least-squares step of the carried Jacobian, kept within the bounds and
    halved once when chi2 does not fall; every run corrects the Jacobian. A step that still
    does not descend renews the free columns by forward differences (relative step
    ``diff_step``) once. It stops when the chi2 decrease the next step predicts is below
    ``tolerance``.

    Returns
    -------
    tuple or None
        The point and its chi2; ``None`` when a simulation fails, a step does not descend on a
        renewed Jacobian either or ``MAX_STEPS`` steps do not settle (re-fit fully then).

    """
    lo, hi = problem.z_lower, problem.z_upper
    z = np.clip(np.asarray(guess, dtype=float), lo, hi)
    try:
        r = problem.residuals(z)
        secant.update(z, r)
        chi2 = float(r @ r)
        renewed = False
        for _ in range(MAX_STEPS):
            jf = secant.jac[:, free]
            step = np.linalg.lstsq(jf, -r, rcond=None)[0]
            if chi2 - float(np.sum((r + jf @ step) ** 2)) < tolerance:
                return z, chi2
            for shrink in (1.0, 0.5):
                trial = z.copy()
                trial[free] = np.clip(z[free] + shrink * step, lo[free], hi[free])
                r_new = problem.residuals(trial)
                secant.update(trial, r_new)
                if float(r_new @ r_new) < chi2:
                    z, r, chi2 = trial, r_new, float(r_new @ r_new)
                    break
            else:
                if renewed:
                    return None
                _renew(problem, z, r, free, secant, diff_step)
                renewed = True
    except FmuError:
        return None
    return None


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
