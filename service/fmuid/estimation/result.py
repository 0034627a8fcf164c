"""The result of a fit: estimates, chi2, the sigmas used and what it cost."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from fmuid.estimation.schema import SCHEMA_VERSION, CostOut, FitResultOut, Written
from fmuid.estimation.space import ParameterSpace
from fmuid.provenance import Provenance

if TYPE_CHECKING:
    from fmuid.estimation.problem import Problem
    from fmuid.estimation.validation import ValidationEntry

__all__ = ["SCHEMA_VERSION", "Cost", "FitResult"]
"""``SCHEMA_VERSION`` is :data:`fmuid.estimation.schema.SCHEMA_VERSION`."""


@dataclass(frozen=True)
class Cost(Written):
    """What a stage cost: FMU simulations run and wall time in seconds.

    ``to_dict`` gives ``{"simulations": ..., "seconds": ...}`` (seconds to the ms).
    """

    schema = CostOut

    simulations: int
    seconds: float


@dataclass(frozen=True)
class FitResult(Written):
    """Best-fit parameters of a study.

    ``to_dict`` writes the JSON of :class:`~fmuid.estimation.schema.FitResultOut`.

    Attributes
    ----------
    fmu_sha256, model_name
        Which FMU was fitted.
    names
        Free parameter names, in the order of ``z``.
    scales
        ``"log"`` or ``"lin"`` per free parameter.
    lower, upper
        Bounds per free parameter, in parameter units.
    estimates
        Best-fit value per free parameter, in parameter units.
    chi2
        Weighted sum of squared residuals at the estimate (thesis eq. 2.20).
    n_data
        Number of fitted data points (residuals).
    sigma
        The sigma used per output (a representative value: the median for per-sample sigmas).
    sigma_method
        How each output's sigma was obtained: ``"given"``, ``"column"`` or ``"estimate: ..."``.
    jacobian
        Weighted residual Jacobian with respect to ``z`` (the fitted, possibly log, coordinates)
        at the estimate, shape ``(n_data, n_free)``.
    fixed
        Values of the FMU parameters that were set but not fitted.
    global_search
        Whether the genetic algorithm gave the start of the trust-region refinement.
    message
        The optimiser's final message.
    cost
        Simulations and wall time of the fit.
    fmu_info
        How the FMU was run: ``fmi_version``, ``interface`` and ``input_handling``.
    units
        Unit of each free and fixed parameter, input and output that declares one in the FMU.
    validation
        Held-out error per test experiment and output (empty without test data).

    """

    fmu_sha256: str
    model_name: str
    names: tuple[str, ...]
    scales: tuple[str, ...]
    lower: dict[str, float]
    upper: dict[str, float]
    estimates: dict[str, float]
    chi2: float
    n_data: int
    sigma: dict[str, float]
    sigma_method: dict[str, str]
    jacobian: np.ndarray = field(repr=False)
    fixed: dict[str, float | str] = field(default_factory=dict)
    global_search: bool = True
    message: str = ""
    cost: Cost = Cost(0, 0.0)
    fmu_info: dict[str, str] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    provenance: Provenance | None = None
    validation: tuple[ValidationEntry, ...] = ()
    problem: Problem | None = field(default=None, repr=False, compare=False)
    """The problem the stage computed it on (set by ``fmuid.fit``, ``profile``, ``diagnose``;
    not written to the JSON): ``write_report(result, folder)`` needs nothing else."""

    schema = FitResultOut

    @property
    def space(self) -> ParameterSpace:
        """The fitted parameters' space: names, scales and bounds."""
        return ParameterSpace.from_bounds(self.names, self.scales, self.lower, self.upper)

    def z_estimate(self) -> np.ndarray:
        """Return the estimate in fitted coordinates (log10 for log-scaled parameters)."""
        return self.space.to_z(self.estimates)

    def fisher_sd_z(self) -> dict[str, float]:
        """Return the asymptotic standard deviation of each parameter in fitted coordinates.

        From the Gauss-Newton approximation ``chi2(z) ~ chi2 + dz' J'J dz``, the profile of
        parameter ``i`` rises as ``dz_i**2 / C_ii`` with ``C = (J'J)^-1``; ``sqrt(C_ii)`` is
        returned (``inf`` for a singular direction).
        """
        jtj = self.jacobian.T @ self.jacobian
        cov = np.linalg.pinv(jtj, rcond=1e-12)
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        u, s, _ = np.linalg.svd(jtj)
        singular = s < s.max() * 1e-12 if s.size else np.zeros(0, bool)
        out = {}
        for i, name in enumerate(self.names):
            weak = bool(np.any(np.abs(u[i, singular]) > 1e-3)) if singular.any() else False
            out[name] = float("inf") if weak or sd[i] == 0 else float(sd[i])
        return out

    def to_frame(self) -> Any:
        """Return a pandas table of the estimates, one row per free parameter (needs pandas).

        Columns: ``estimate``, ``unit``, ``lower``, ``upper`` (bounds), ``scale``, ``at_bound``.
        """
        from fmuid.frames import parameter_frame

        columns = ("estimate", "unit", "lower", "upper", "scale", "at_bound")
        params = self.to_dict()["parameters"]
        return parameter_frame({n: {c: p[c] for c in columns} for n, p in params.items()})
