"""Exact profile crossings computed by the tests: scipy root-finding on multi-start re-fits.

Independent of the profile engine: each profile value is the smallest chi2 of scipy
``least_squares`` re-fits of the other parameters from several starts (the optimum, the previous
re-fit, seeded Latin-hypercube points), and the crossing is found by ``brentq`` on it.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq, least_squares
from scipy.stats import qmc

from fmuid.estimation.problem import Problem


class ReferenceProfile:
    """Profile of one parameter of ``problem`` by multi-start re-fits (fitted coordinates)."""

    def __init__(self, problem: Problem, index: int, z_hat: np.ndarray, starts: int = 3):
        self.problem = problem
        self.index = index
        self.z_hat = np.asarray(z_hat, dtype=float)
        self.free = np.ones(problem.n_free, bool)
        self.free[index] = False
        lo, hi = problem.z_lower, problem.z_upper
        unit = qmc.LatinHypercube(d=problem.n_free, seed=np.random.default_rng(2024)).random(starts)
        self.diverse = [lo + u * (hi - lo) for u in unit]
        self.last = self.z_hat.copy()

    def chi2(self, zi: float) -> float:
        """Smallest re-fitted chi2 with the parameter fixed at ``zi``."""
        lo, hi = self.problem.z_lower[self.free], self.problem.z_upper[self.free]
        best = np.inf
        best_z = None
        for start in [self.z_hat, self.last, *self.diverse]:
            z = np.array(start, dtype=float)
            z[self.index] = zi

            def fun(x: np.ndarray, z: np.ndarray = z) -> np.ndarray:
                z = z.copy()
                z[self.free] = x
                return self.problem.residuals(z)

            x0 = np.clip(z[self.free], lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
            res = least_squares(
                fun,
                x0,
                bounds=(lo, hi),
                method="trf",
                x_scale="jac",
                ftol=1e-10,
                xtol=1e-10,
                gtol=1e-10,
                diff_step=1e-7,
            )
            if 2.0 * res.cost < best:
                best = 2.0 * res.cost
                best_z = z.copy()
                best_z[self.free] = res.x
        self.last = best_z if best_z is not None else self.last
        return float(best)

    def crossing(self, chi2_hat: float, threshold: float, z_guess: float) -> float | None:
        """The crossing of ``chi2_hat + threshold`` between the estimate and beyond ``z_guess``.

        Returns ``None`` when the profile stays below the threshold up to the bound.
        """
        zi_hat = float(self.z_hat[self.index])
        direction = np.sign(z_guess - zi_hat)
        bound = (self.problem.z_upper if direction > 0 else self.problem.z_lower)[self.index]
        half = abs(z_guess - zi_hat)
        inner, outer = (
            zi_hat,
            float(np.clip(z_guess + 0.3 * direction * half, *sorted((zi_hat, bound)))),
        )

        def g(zi: float) -> float:
            return self.chi2(zi) - chi2_hat - threshold

        while g(outer) < 0:
            if outer == bound:
                return None
            inner = outer
            outer = float(np.clip(outer + direction * half, *sorted((zi_hat, bound))))
        return float(brentq(g, inner, outer, xtol=1e-5 * half, rtol=1e-12))
