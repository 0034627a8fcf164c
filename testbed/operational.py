"""Operational concealment checks, computed without ``fmuid.diagnose``.

An effect is *concealed* in a data set when the base model fitted to it (the six tire
parameters free, ``fmuid``'s public fit) leaves residuals that look like noise, while the true
augmentation is decisively better:

- Ljung-Box whiteness at 5 % passes on every output of every experiment,
- the reduced chi2 lies in the central 95 % of chi2(n - p) / (n - p),
- the likelihood-ratio test of the true augmentation (chi2 with 1 df on the chi2 drop) has
  a p-value between 1e-12 and 1e-3.

The true augmentation is written here, on top of the FMU's simulator: the FMU parameters
``alpha_sat`` / ``slope`` for the physics it can switch on, and for the others a wrapper around
the simulation (a first-order lag of the outputs or of the input, a delayed input, an offset on
the input, a bias on one output), fitted with ``scipy.optimize.least_squares``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats
from scipy.optimize import least_squares

import fieldtruth as ft
from fmuid.data import Experiment, Spec, spec_from_json
from fmuid.estimation.optimize import fit_problem
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.model.builtin import builtin_fmu
from fmuid.model.registry import get_simulator
from fmuid.stages import make_problem

OUTPUTS = ("gam_t", "gam_i")
LEVEL = 0.05
"""Ljung-Box level per channel."""
BAND = 0.95
"""Central probability of the reduced-chi2 noise band."""
P_RANGE = (1e-12, 1e-3)
"""The likelihood-ratio p-values that count as "decisive but not obvious"."""
FINE_STEP = 0.02
"""Grid [s] on which lags are integrated (exactly for piecewise-linear signals)."""
SWITCHED = {"tire_saturation": "alpha_sat", "side_slope": "slope"}
"""Effects that are FMU parameters (off at 0)."""
AUGMENTATION_BOUNDS = {
    "output_lag": (0.0, 1.0),
    "input_delay": (0.0, 1.0),
    "input_lag": (0.0, 1.0),
    "input_offset": (-0.1, 0.1),
    "output_bias": (-0.1, 0.1),
    "tire_saturation": (1e-3, 2.0),
    "side_slope": (-0.5, 0.5),
}
"""Bounds of the added parameter of each catalogued effect (its unit)."""


def study_spec() -> Spec:
    """The six tire parameters free (thesis Table 3.2), sigma from the columns, local fit."""
    return spec_from_json(
        json.dumps(
            {
                "parameters": {
                    n: {"start": ft.NOMINAL[n], "lower": lo, "upper": hi}
                    for n, (lo, hi) in ft.BOUNDS.items()
                },
                "inputs": ["delta"],
                "outputs": {o: {"sigma": "column"} for o in OUTPUTS},
                "global_search": False,
            }
        )
    )


def base_fit(
    experiments: Sequence[Experiment], starts: Sequence[Mapping[str, float]]
) -> tuple[Problem, FitResult]:
    """Fit the base model (tires free) from each start; return the problem and the best fit."""
    problem = make_problem(builtin_fmu("tractor_implement"), experiments, study_spec())
    unique = {tuple(sorted(s.items())): dict(s) for s in starts}.values()
    fits = [fit_problem(problem, start=s, global_search=False) for s in unique]
    return problem, min(fits, key=lambda f: f.chi2)


def channel_residuals(problem: Problem, fit: FitResult) -> dict[str, np.ndarray]:
    """Weighted residuals of the fit per ``"<experiment>:<output>"``, in time order."""
    r = problem.residuals(problem.to_z(fit.estimates))
    out, k = {}, 0
    for exp, masks in zip(problem.experiments, problem.masks):
        for output, mask in zip(problem.outputs, masks):
            n = int(mask.sum())
            out[f"{exp.name}:{output}"] = r[k : k + n]
            k += n
    return out


def ljung_box(residuals: np.ndarray, lags: int | None = None) -> float:
    """P-value of the Ljung-Box test with ``min(20, n // 5)`` lags (chi2 with ``lags`` df)."""
    x = np.asarray(residuals, float) - np.mean(residuals)
    n = len(x)
    h = lags or min(20, n // 5)
    denom = float(x @ x)
    acf = np.array([float(x[:-k] @ x[k:]) / denom for k in range(1, h + 1)])
    q = n * (n + 2) * float(np.sum(acf**2 / (n - np.arange(1, h + 1))))
    return float(stats.chi2.sf(q, h))


def chi2_band(n_data: int, n_free: int, level: float = BAND) -> tuple[float, float]:
    """Central ``level`` interval of the reduced chi2 of pure noise, chi2(n - p) / (n - p)."""
    dof = n_data - n_free
    tail = (1.0 - level) / 2
    return float(stats.chi2.ppf(tail, dof) / dof), float(stats.chi2.isf(tail, dof) / dof)


def first_order_lag(t: np.ndarray, y: np.ndarray, tau: float) -> np.ndarray:
    """Response of ``x' = (y - x) / tau``, ``x(t0) = y(t0)``, to ``y`` linear between samples."""
    if tau <= 0:
        return np.asarray(y, float).copy()
    h = np.diff(t)
    a = np.exp(-h / tau)
    ramp = 1.0 - tau * (1.0 - a) / h
    x = np.empty(len(y))
    x[0] = y[0]
    for k in range(len(h)):
        x[k + 1] = a[k] * x[k] + (1.0 - a[k]) * y[k] + ramp[k] * (y[k + 1] - y[k])
    return x


def augmented_outputs(
    experiment: Experiment,
    params: Mapping[str, float],
    effect: str,
    magnitude: float,
    bias_output: str = "gam_t",
) -> dict[str, np.ndarray]:
    """Outputs of the FMU with the true augmentation, at the experiment's output rows.

    Parameters
    ----------
    experiment
        The recording (its ``delta`` samples and output rows).
    params
        FMU parameter values (the tires).
    effect, magnitude
        A catalogued effect and its parameter (unit of ``AUGMENTATION_BOUNDS``).
    bias_output
        The channel that ``output_bias`` shifts.
    """
    sim = get_simulator(builtin_fmu("tractor_implement"))
    t_in, u_in = experiment.input_samples("delta")
    t_out = experiment.time[experiment.output_mask(OUTPUTS[0])]
    values = dict(params)
    if effect in SWITCHED:
        values[SWITCHED[effect]] = magnitude
    t0, t1 = float(min(t_in[0], t_out[0])), float(max(t_in[-1], t_out[-1]))
    fine = np.union1d(t_in, np.arange(t0, t1 + 1e-9, FINE_STEP))
    if effect == "input_delay":
        grid = np.union1d(t_in, np.clip(t_in + magnitude, t0, t1))
        u_sim, t_sim = np.interp(grid - magnitude, t_in, u_in), grid
    elif effect == "input_lag":
        u_sim, t_sim = first_order_lag(fine, np.interp(fine, t_in, u_in), magnitude), fine
    elif effect == "input_offset":
        u_sim, t_sim = u_in + magnitude, t_in
    else:
        u_sim, t_sim = u_in, t_in
    if effect == "output_lag":
        grid = np.union1d(t_out, fine)
        y = sim.simulate(values, t_sim, {"delta": u_sim}, grid, list(OUTPUTS))
        rows = np.searchsorted(grid, t_out)
        return {o: first_order_lag(grid, y[:, j], magnitude)[rows] for j, o in enumerate(OUTPUTS)}
    y = sim.simulate(values, t_sim, {"delta": u_sim}, t_out, list(OUTPUTS))
    out = {o: y[:, j].copy() for j, o in enumerate(OUTPUTS)}
    if effect == "output_bias":
        out[bias_output] += magnitude
    return out


def augmented_fit(
    experiments: Sequence[Experiment],
    effect: str,
    tires: Mapping[str, float],
    magnitude: float,
    bias_output: str = "gam_t",
) -> tuple[float, float]:
    """Fit the tires and the added parameter; return the chi2 and the fitted magnitude.

    Warm-started at ``tires`` (the base fit) and the true ``magnitude``; tires in log10.
    """
    names = list(ft.BOUNDS)
    lo_m, hi_m = AUGMENTATION_BOUNDS[effect]
    lower = np.array([np.log10(ft.BOUNDS[n][0]) for n in names] + [lo_m])
    upper = np.array([np.log10(ft.BOUNDS[n][1]) for n in names] + [hi_m])
    x0 = np.array([np.log10(tires[n]) for n in names] + [magnitude])
    x0 = np.clip(x0, lower + 1e-9 * (upper - lower), upper - 1e-9 * (upper - lower))
    data = []
    for exp in experiments:
        mask = exp.output_mask(OUTPUTS[0])
        data.append({o: (exp.columns[o][mask], exp.columns[f"sigma_{o}"][mask]) for o in OUTPUTS})

    def residuals(x: np.ndarray) -> np.ndarray:
        params = {n: float(10.0**v) for n, v in zip(names, x[:-1])}
        parts = []
        for exp, d in zip(experiments, data):
            y = augmented_outputs(exp, params, effect, float(x[-1]), bias_output)
            parts += [(d[o][0] - y[o]) / d[o][1] for o in OUTPUTS]
        return np.concatenate(parts)

    res = least_squares(
        residuals,
        x0,
        bounds=(lower, upper),
        method="trf",
        x_scale="jac",
        diff_step=1e-6,
        ftol=1e-10,
        xtol=1e-10,
        gtol=1e-10,
        max_nfev=200,
    )
    return float(res.fun @ res.fun), float(res.x[-1])


@dataclass(frozen=True)
class Check:
    """The operational criteria of one data set.

    Attributes
    ----------
    chi2_base, n_data, n_free
        Base fit's chi2, number of fitted samples and of free parameters.
    band
        Noise band of the reduced chi2.
    ljung_box
        Ljung-Box p-value per ``"<experiment>:<output>"``.
    chi2_augmented, magnitude_fit
        The true augmentation's chi2 and fitted magnitude (``None`` when not catalogued).
    base
        The base fit's tire estimates.
    """

    chi2_base: float
    n_data: int
    n_free: int
    band: tuple[float, float]
    ljung_box: dict[str, float]
    chi2_augmented: float | None
    magnitude_fit: float | None
    base: dict[str, float]

    @property
    def reduced_chi2(self) -> float:
        """Base chi2 per degree of freedom."""
        return self.chi2_base / (self.n_data - self.n_free)

    @property
    def lrt_p(self) -> float | None:
        """P-value of the likelihood-ratio test of the augmentation (chi2, 1 df)."""
        if self.chi2_augmented is None:
            return None
        return float(stats.chi2.sf(max(self.chi2_base - self.chi2_augmented, 0.0), 1))

    def failures(self) -> list[str]:
        """Which criteria fail (empty when the effect is concealed)."""
        out = [f"ljung_box {k} p={p:.3g}" for k, p in self.ljung_box.items() if p < LEVEL]
        if not self.band[0] <= self.reduced_chi2 <= self.band[1]:
            out.append(f"reduced chi2 {self.reduced_chi2:.3f} outside {self.band}")
        p = self.lrt_p
        if p is not None and not P_RANGE[0] <= p <= P_RANGE[1]:
            out.append(f"lrt p={p:.3g} outside {P_RANGE}")
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "chi2_base": self.chi2_base,
            "n_data": self.n_data,
            "n_free": self.n_free,
            "reduced_chi2": self.reduced_chi2,
            "band": list(self.band),
            "ljung_box": self.ljung_box,
            "chi2_augmented": self.chi2_augmented,
            "lrt_p": self.lrt_p,
            "magnitude_fit": self.magnitude_fit,
            "base": self.base,
            "failures": self.failures(),
        }


def check_case(
    experiments: Sequence[Experiment],
    effect: str | None,
    magnitude: float,
    starts: Sequence[Mapping[str, float]],
    bias_output: str = "gam_t",
) -> Check:
    """Fit the base model and (for catalogued effects) the true augmentation; test both.

    Parameters
    ----------
    experiments
        The recordings.
    effect, magnitude
        The true effect and its size (the augmentation's warm start).
    starts
        Tire values to start the base fit from (the best fit wins).
    bias_output
        The biased channel of ``output_bias``.
    """
    problem, fit = base_fit(experiments, starts)
    lb = {k: ljung_box(r) for k, r in channel_residuals(problem, fit).items()}
    chi2_aug = m_fit = None
    if effect in AUGMENTATION_BOUNDS:
        chi2_aug, m_fit = augmented_fit(experiments, effect, fit.estimates, magnitude, bias_output)
    return Check(
        chi2_base=float(fit.chi2),
        n_data=problem.n_data,
        n_free=problem.n_free,
        band=chi2_band(problem.n_data, problem.n_free),
        ljung_box=lb,
        chi2_augmented=chi2_aug,
        magnitude_fit=m_fit,
        base=dict(fit.estimates),
    )
