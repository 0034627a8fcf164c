"""Small hand-built results for the plot and report tests (no FMU, no engine)."""

from __future__ import annotations

import numpy as np

from fmuid.estimation.result import Cost, FitResult
from fmuid.profiling.result import ParameterProfile, ProfilePoint, ProfileResult

THRESHOLDS = {"pointwise": 0.989, "simultaneous": 2.28}
CHI2_OPT = 10.0


def toy_fit() -> FitResult:
    # J'J = diag(100, 25): Fisher sd_z = 0.1 for m and 0.2 for k
    jac = np.array([[10.0, 0.0], [0.0, 5.0], [0.0, 0.0]])
    return FitResult(
        fmu_sha256="abc",
        model_name="toy",
        names=("m", "k"),
        scales=("log", "log"),
        lower={"m": 0.01, "k": 0.1},
        upper={"m": 100.0, "k": 1000.0},
        estimates={"m": 1.0, "k": 10.0},
        chi2=CHI2_OPT,
        n_data=3,
        sigma={"x": 0.1},
        sigma_method={"x": "given"},
        jacobian=jac,
        cost=Cost(10, 0.5),
    )


def _points(name: str, other: str, est: float, sd: float, other_est: float) -> tuple:
    zs = np.linspace(-3 * sd, 3 * sd, 13)
    pts = []
    for i, dz in enumerate(zs):
        at_bound = (other,) if i == 0 else ()
        error = "simulation failed" if i == 12 else None
        pts.append(
            ProfilePoint(
                value=est * 10**dz,
                chi2=float("nan") if error else CHI2_OPT + (dz / sd) ** 2,
                params={other: other_est * 10 ** (-0.5 * dz)},
                at_bound=at_bound,
                error=error,
            )
        )
    return tuple(pts)


def toy_profile_result() -> ProfileResult:
    """Two log-scaled parameters with exact quadratic profiles (sd_z 0.1 and 0.2)."""
    fit = toy_fit()
    sd = {"m": 0.1, "k": 0.2}
    params = {}
    for name, other in (("m", "k"), ("k", "m")):
        est = fit.estimates[name]
        half = sd[name] * np.sqrt(THRESHOLDS["simultaneous"])
        half_p = sd[name] * np.sqrt(THRESHOLDS["pointwise"])
        params[name] = ParameterProfile(
            name=name,
            estimate=est,
            lower=fit.lower[name],
            upper=fit.upper[name],
            scale="log",
            ci_simultaneous=(est * 10**-half, None if name == "k" else est * 10**half),
            ci_pointwise=(est * 10**-half_p, est * 10**half_p),
            status="identifiable" if name == "m" else "practically_non_identifiable",
            points=_points(name, other, est, sd[name], fit.estimates[other]),
            fisher_sd_z=sd[name],
        )
    return ProfileResult(
        fit=fit,
        confidence=0.68,
        thresholds=dict(THRESHOLDS),
        parameters=params,
        better_optimum_found=False,
        structural_check={
            "singular_values": [10.0, 5.0],
            "non_identifiable_combinations": [],
        },
        cost=Cost(200, 3.0),
    )
