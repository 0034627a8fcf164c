"""Re-fits along one profile branch that start from the previous re-fit's Jacobian."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from fmuid.errors import FmuError
from fmuid.estimation.optimize import FAILED_RESIDUAL, FitOptions, refine, safe_residuals
from fmuid.estimation.problem import Problem


class BranchRefit:
    """Re-fit the other parameters with parameter ``index`` fixed, reusing Jacobians.

    Consecutive points of a branch lie close together, so the finite-difference Jacobian that
    the trust-region method computes at the end of one re-fit is a good Jacobian for the start
    of the next: it is handed over instead of being recomputed (the optimiser computes fresh
    ones for every later iteration, so its tolerances and its answer keep their meaning). That
    saves one Jacobian (one simulation per free parameter) per re-fit. Re-fits polished by
    Powell's method (a non-smooth objective) go through :func:`fmuid.estimation.optimize.refine`.

    Parameters
    ----------
    problem
        The estimation problem.
    index
        The fixed (profiled) parameter.
    options
        Tolerances and finite-difference step of the re-fits.

    """

    def __init__(self, problem: Problem, index: int, options: FitOptions) -> None:
        self.problem = problem
        self.options = options
        self.free = np.ones(problem.n_free, bool)
        self.free[index] = False
        self.jac: np.ndarray | None = None

    def __call__(self, z0: np.ndarray) -> tuple[np.ndarray, float]:
        """Re-fit from ``z0`` (all parameters, fitted coordinates); return the point and chi2.

        Raises
        ------
        FmuError
            When the simulation fails at every trial point.

        """
        if self.options.polish:
            z, chi2, _ = refine(self.problem, z0, free=self.free, options=self.options)
            return z, chi2
        problem, free = self.problem, self.free
        lo, hi = problem.z_lower[free], problem.z_upper[free]
        span = hi - lo
        z_full = np.array(z0, dtype=float)
        x0 = np.clip(z_full[free], lo + 1e-9 * span, hi - 1e-9 * span)
        last: dict[str, np.ndarray] = {}

        def fun(x: np.ndarray) -> np.ndarray:
            z = z_full.copy()
            z[free] = x
            last["x"], last["f"] = x.copy(), safe_residuals(problem, z)
            return last["f"]

        handed = [self.jac]

        def jac(x: np.ndarray) -> np.ndarray:
            if handed[0] is not None:
                j, handed[0] = handed[0], None
                return j
            f = last["f"] if np.array_equal(last.get("x"), x) else fun(x)
            self.jac = self._differences(fun, x, f, lo, hi)
            return self.jac

        res = least_squares(
            fun, x0, jac=jac, bounds=(lo, hi), method="trf", ftol=self.options.ftol,
            xtol=self.options.xtol, gtol=self.options.gtol, x_scale="jac",
            max_nfev=self.options.max_nfev or 100 * (int(free.sum()) + 1),
        )  # fmt: skip
        if np.all(res.fun == FAILED_RESIDUAL):
            self.jac = None
            raise FmuError(f"{problem.fmu_path.name}: the simulation failed at every trial point")
        z_full[free] = res.x
        return z_full, float(2.0 * res.cost)

    def _differences(
        self, fun, x: np.ndarray, f: np.ndarray, lo: np.ndarray, hi: np.ndarray
    ) -> np.ndarray:  # noqa: ANN001 - fun is the closure above
        """Forward differences with scipy's relative step, backwards at an upper bound."""
        out = np.empty((f.size, x.size))
        for k in range(x.size):
            h = self.options.diff_step * max(1.0, abs(x[k])) * (1.0 if x[k] >= 0 else -1.0)
            if not lo[k] <= x[k] + h <= hi[k]:
                h = -h
            xk = x.copy()
            xk[k] += h
            out[:, k] = (fun(xk) - f) / h
        return out
