"""Concealed cases on a user's FMU: a DC motor exported by pythonfmu, its truth solved by scipy.

The FMU (``testbed/pythonfmu_src/dc_motor.py``, built at bench time) is the textbook model
``L i' = V - R i - K w``, ``J w' = K i - b w``; the study fits R, J and b (L and K as
exported). The truth is the same equations solved here exactly for an input linear between its
samples (per eigenmode, run by ``scipy.signal.lfilter``; a delayed, clipped or lagged voltage is
taken as linear on a grid 20 times finer) with one left-out effect applied outside the motor:

- on the voltage: ``input_delay`` (s), ``input_lag`` (s, first order), ``input_offset`` (V),
  ``input_gain`` (factor), ``input_saturation`` (a symmetric clip at a fraction of the peak);
- on one measured output: ``output_bias``, ``output_gain``, ``output_lag`` (s),
  ``output_saturation`` (a clip of the top or bottom of its range).

A case draws R, J, b log-normal 20 % off the exported values, a step-sequence and a multisine
record (1 s each at 1 kHz, peak 6-12 V, steps ramped over 10 ms), an SNR of 25-100 per record
(sigma of each output ``max|y| / SNR`` of the motion without the effect), the channel and sign,
and a target noncentrality; the magnitude is searched so that the base model's chi2 on the
noise-free data is that target (:mod:`concealed`'s secant search, here with scipy fits). Then
noise is drawn until the operational criteria hold: Ljung-Box at 5 % on every channel, the
reduced chi2 in its 95 % noise band and the true augmentation's likelihood-ratio p in
[1e-12, 1e-3] (fits by ``scipy.optimize.least_squares`` on the scipy solution, independent of
fmuid). Controls are the same draws with no effect.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal
from scipy.optimize import least_squares

from fmuid.data import Experiment, load_experiment
from fmuid.data.experiment import experiment_from_arrays
from operational import P_RANGE, chi2_band, ljung_box

VERSION = 1
"""Bumped when the generator changes; cached cases of another version are made again."""
NOMINAL = {"R": 1.0, "L": 0.005, "K": 0.05, "J": 0.001, "b": 0.001}
"""The FMU's exported parameter values."""
FREE = {"R": (0.1, 10.0), "J": (1e-4, 1e-2), "b": (1e-4, 1e-2)}
"""The study's free parameters and bounds."""
OUTPUTS = ("i", "w")
RATE = 1000.0
DURATION = 1.0
EFFECTS = (
    "input_delay",
    "input_lag",
    "input_offset",
    "input_gain",
    "input_saturation",
    "output_bias",
    "output_gain",
    "output_lag",
    "output_saturation",
)
STRENGTH = {
    "input_delay": (0.002, 1e-5, 0.05),
    "input_lag": (0.002, 1e-5, 0.05),
    "output_lag": (0.002, 1e-5, 0.05),
    "input_offset": (0.01, 1e-6, 0.3),
    "output_bias": (0.01, 1e-6, 0.3),
    "input_gain": (0.02, 1e-5, 0.5),
    "output_gain": (0.02, 1e-5, 0.5),
    "input_saturation": (0.05, 1e-4, 0.7),
    "output_saturation": (0.05, 1e-4, 0.7),
}
"""First strength and its range per effect (strength units: see :func:`apply_effect`)."""
LAMBDA_RANGE = (15.0, 45.0)
ATTEMPTS = 10
MAX_SEARCH = 12
TOLERANCE = 1.1
FINE = 20
"""Sub-intervals per sample on which a delayed, clipped or lagged voltage is taken as linear."""
CODE = {None: 0, **{e: i + 1 for i, e in enumerate(EFFECTS)}}


@dataclass(frozen=True)
class Run:
    """One record: name, time [s], voltage [V], noise sigma per output, SNR."""

    name: str
    t: np.ndarray
    v: np.ndarray
    sigma: dict[str, float]
    snr: float


@dataclass(frozen=True)
class Design:
    """A case without its magnitude and noise: truth, records, channel, sign, lambda target."""

    effect: str | None
    seed: int
    truth: dict[str, float]
    runs: tuple[Run, ...]
    channel: str
    sign: float
    target_lambda: float


def foh_modes(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, t: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """Outputs ``c x`` of ``x' = a x + b u`` from ``x(t0) = 0``, ``u`` linear between samples.

    Exact on an equally spaced grid: per eigenmode ``z' = lam z + beta u`` the step is
    ``z+ = e^(lam h) z + beta (g0 u_k + g1 (u_(k+1) - u_k))`` with ``g0 = (e^(lam h) - 1) / lam``
    and ``g1 = (e^(lam h) - 1 - lam h) / (lam^2 h)``, run by ``scipy.signal.lfilter``.
    """
    h = float(t[1] - t[0])
    if not np.allclose(np.diff(t), h, rtol=1e-9, atol=1e-12):
        raise ValueError("foh_modes needs an equally spaced grid")
    lam, vec = np.linalg.eig(a)
    beta = np.linalg.solve(vec, b.reshape(-1))
    modes = []
    for l_k, b_k in zip(lam, beta):
        e = np.exp(l_k * h)
        g0 = (e - 1.0) / l_k
        g1 = (e - 1.0 - l_k * h) / (l_k * l_k * h)
        z = signal.lfilter([b_k * g1, b_k * (g0 - g1)], [1.0, -e], u.astype(complex))
        modes.append(z - e ** np.arange(len(u)) * z[0])
    return np.real(np.asarray(modes).T @ (c @ vec).T)


def motor(
    p: Mapping[str, float],
    t: np.ndarray,
    v: np.ndarray,
    lag: float = 0.0,
    lag_output: int | None = None,
) -> np.ndarray:
    """Current and speed (n x 2) for a voltage linear between samples, from rest.

    ``lag_output`` (0 or 1) is seen through a first-order sensor lag ``lag`` [s] started at
    its initial value (rest: zero).
    """
    a = np.array([[-p["R"] / p["L"], -p["K"] / p["L"]], [p["K"] / p["J"], -p["b"] / p["J"]]])
    b = np.array([1.0 / p["L"], 0.0])
    c = np.eye(2)
    if lag_output is not None and lag > 0:
        a = np.block([[a, np.zeros((2, 1))], [c[[lag_output]] / lag, -np.ones((1, 1)) / lag]])
        b = np.append(b, 0.0)
        c = np.hstack([c, np.zeros((2, 1))])
        c[lag_output] = [0.0, 0.0, 1.0]
    return foh_modes(a, b, c, t, v)


def first_order(t: np.ndarray, u: np.ndarray, tau: float) -> np.ndarray:
    """``x' = (u - x) / tau`` from ``x = u[0]``, ``u`` linear between samples (exact)."""
    if tau <= 0:
        return u.copy()
    x = foh_modes(np.array([[-1.0 / tau]]), np.array([1.0 / tau]), np.eye(1), t, u - u[0])
    return x[:, 0] + u[0]


def apply_effect(
    p: Mapping[str, float], run: Run, effect: str | None, m: float, channel: str
) -> np.ndarray:
    """Outputs (n x 2) of ``run`` with ``effect`` of magnitude ``m`` (its catalogue unit).

    Delays and lags [s]; offsets and biases in the signal's unit; gains as factors; a
    saturation's ``m`` is the clip level (input: symmetric at +-m V; output: the top when the
    case's sign is positive, stored as ``m`` > 0 for the top and ``-m`` for the bottom).
    """
    t, v, k = run.t, run.v, OUTPUTS.index(channel)
    if effect in ("input_delay", "input_saturation", "input_lag"):
        fine = np.linspace(t[0], t[-1], FINE * (len(t) - 1) + 1)
        u = np.interp(fine, t, v)
        if effect == "input_delay":
            u = np.interp(fine - m, t, v)
        elif effect == "input_saturation":
            u = np.clip(u, -m, m)
        else:
            u = first_order(fine, u, m)
        return motor(p, fine, u)[::FINE]
    if effect == "input_offset":
        return motor(p, t, v + m)
    if effect == "input_gain":
        return motor(p, t, v * m)
    if effect == "output_lag":
        return motor(p, t, v, m, k)
    y = motor(p, t, v)
    if effect == "output_bias":
        y[:, k] += m
    elif effect == "output_gain":
        y[:, k] *= m
    elif effect == "output_saturation":
        y[:, k] = np.minimum(y[:, k], m) if m > 0 else np.maximum(y[:, k], m)
    return y


def magnitude_of(design: Design, strength: float) -> float:
    """The effect's parameter for a search strength (see :data:`STRENGTH`)."""
    effect, sign = design.effect, design.sign
    if effect in ("input_gain", "output_gain"):
        return 1.0 + sign * strength
    if effect == "input_offset":
        return sign * strength * max(float(np.max(np.abs(r.v))) for r in design.runs)
    k = OUTPUTS.index(design.channel)
    peak = [motor(design.truth, r.t, r.v)[:, k] for r in design.runs]
    if effect == "output_bias":
        return sign * strength * max(float(np.max(np.abs(y))) for y in peak)
    if effect == "input_saturation":
        return (1.0 - strength) * max(float(np.max(np.abs(r.v))) for r in design.runs)
    if effect == "output_saturation":
        top = (
            max(float(np.max(y)) for y in peak) if sign > 0 else min(float(np.min(y)) for y in peak)
        )
        return (1.0 - strength) * top
    return strength


def voltage(rng: np.random.Generator, t: np.ndarray, kind: str, peak: float) -> np.ndarray:
    """A step sequence (levels held 0.1-0.25 s, ramped over 10 ms) or a 1-40 Hz multisine."""
    if kind == "steps":
        edges, levels = [0.05], [0.0]
        while edges[-1] < t[-1]:
            edges.append(edges[-1] + float(rng.uniform(0.1, 0.25)))
            levels.append(float(rng.uniform(-1.0, 1.0)) * peak)
        knots_t = np.concatenate(
            [[t[0]], np.repeat(edges[:-1], 2) + np.tile([0, 0.01], len(edges) - 1)]
        )
        knots_v = np.concatenate([[0.0], np.repeat(levels, 2)[1:-1]])
        return np.interp(t, knots_t, knots_v[: len(knots_t)])
    freqs = np.sort(rng.uniform(1.0, 40.0, 10))
    phases = rng.uniform(0.0, 2 * np.pi, 10)
    u = np.sum(np.sin(2 * np.pi * freqs[:, None] * t[None, :] + phases[:, None]), axis=0)
    return peak * u / np.max(np.abs(u))


def draw_design(effect: str | None, seed: int) -> Design:
    """Draw the truth, records, SNR, channel, sign and lambda target of a case."""
    rng = np.random.default_rng([seed, CODE[effect], VERSION])
    truth = dict(NOMINAL)
    for name in FREE:
        truth[name] = NOMINAL[name] * float(np.exp(rng.normal(0.0, 0.2)))
    channel = str(rng.choice(OUTPUTS))
    sign = float(rng.choice([-1.0, 1.0]))
    target = float(np.exp(rng.uniform(*np.log(LAMBDA_RANGE))))
    t = np.round(np.arange(0.0, DURATION + 1e-9, 1.0 / RATE), 6)
    runs = []
    for kind in ("steps", "multisine"):
        v = voltage(rng, t, kind, float(rng.uniform(6.0, 12.0)))
        snr = float(rng.uniform(25.0, 100.0))
        y = motor(truth, t, v)
        sigma = {o: float(np.max(np.abs(y[:, k]))) / snr for k, o in enumerate(OUTPUTS)}
        runs.append(Run(f"{kind}.csv", t, v, sigma, snr))
    return Design(effect, seed, truth, tuple(runs), channel, sign, target)


def outputs(design: Design, p: Mapping[str, float], m: float) -> list[np.ndarray]:
    """Each run's outputs with the design's effect at magnitude ``m``."""
    return [apply_effect(p, r, design.effect, m, design.channel) for r in design.runs]


def weighted_fit(
    design: Design, data: list[np.ndarray], start: Mapping[str, float], with_effect: float | None
) -> tuple[float, dict[str, float], float | None]:
    """Least-squares fit of R, J, b (log10) and, when ``with_effect`` is a start, the magnitude.

    Returns the chi2, the parameters and the fitted magnitude (``None`` for the base model).
    """
    names = list(FREE)
    x0 = [math.log10(start[n]) for n in names]
    lower = [math.log10(FREE[n][0]) for n in names]
    upper = [math.log10(FREE[n][1]) for n in names]
    if with_effect is not None:
        x0.append(with_effect)
        lower.append(-np.inf)
        upper.append(np.inf)
    sig = [np.array([r.sigma[o] for o in OUTPUTS]) for r in design.runs]

    def residuals(x: np.ndarray) -> np.ndarray:
        p = {**design.truth, **{n: 10.0 ** float(v) for n, v in zip(names, x)}}
        m = float(x[-1]) if with_effect is not None else 0.0
        effect = design.effect if with_effect is not None else None
        y = [apply_effect(p, r, effect, m, design.channel) for r in design.runs]
        return np.concatenate([((d - s) / w).ravel() for d, s, w in zip(data, y, sig)])

    res = least_squares(
        residuals,
        np.array(x0),
        bounds=(lower, upper),
        x_scale="jac",
        diff_step=1e-7,
        ftol=1e-12,
        xtol=1e-12,
        gtol=1e-12,
        max_nfev=300,
    )
    params = {n: 10.0 ** float(v) for n, v in zip(names, res.x)}
    return float(res.fun @ res.fun), params, (float(res.x[-1]) if with_effect is not None else None)


def calibrate(design: Design) -> tuple[float, float, dict[str, float]]:
    """The magnitude whose noise-free base chi2 is the target; its lambda and base fit."""
    first, lo, hi = STRENGTH[str(design.effect)]
    s, slope, start = first, 2.0, {n: design.truth[n] for n in FREE}
    below = above = None
    best: tuple[float, float, float, dict[str, float]] = (math.inf, 0.0, 0.0, start)
    for _ in range(MAX_SEARCH):
        m = magnitude_of(design, s)
        lam, start, _ = weighted_fit(design, outputs(design, design.truth, m), start, None)
        lam = max(lam, 1e-12)
        gap = abs(math.log(lam / design.target_lambda))
        if gap < best[0]:
            best = (gap, m, lam, start)
        if gap < math.log(TOLERANCE):
            break
        if lam < design.target_lambda:
            below = (s, lam)
        else:
            above = (s, lam)
        if below and above:
            slope = min(
                max(math.log(above[1] / below[1]) / math.log(above[0] / below[0]), 0.5), 6.0
            )
            s_new = below[0] * (design.target_lambda / below[1]) ** (1.0 / slope)
            if not min(below[0], above[0]) < s_new < max(below[0], above[0]):
                s_new = math.sqrt(below[0] * above[0])
        else:
            s_new = s * min(max((design.target_lambda / lam) ** (1.0 / slope), 0.1), 10.0)
        s = min(max(s_new, lo), hi)
    return best[1], best[2], best[3]


def noisy(design: Design, clean: list[np.ndarray], noise: list[int]) -> list[np.ndarray]:
    """Add each output's Gaussian noise (its run's sigma) drawn from seed ``noise``."""
    rng = np.random.default_rng(noise)
    sig = [np.array([r.sigma[o] for o in OUTPUTS]) for r in design.runs]
    return [y + rng.normal(0.0, 1.0, y.shape) * s for y, s in zip(clean, sig)]


def check(
    design: Design, data: list[np.ndarray], m: float, start: Mapping[str, float]
) -> dict[str, Any]:
    """The operational criteria of a data set (base fit, Ljung-Box, noise band, LR p)."""
    from scipy import stats

    chi2, base, _ = weighted_fit(design, data, start, None)
    p = {**design.truth, **base}
    lb = {}
    for r, d in zip(design.runs, data):
        y = motor(p, r.t, r.v)
        for k, o in enumerate(OUTPUTS):
            lb[f"{r.name}:{o}"] = ljung_box((d[:, k] - y[:, k]) / r.sigma[o])
    n = sum(d.size for d in data)
    band = chi2_band(n, len(FREE))
    out: dict[str, Any] = {
        "chi2_base": chi2,
        "reduced_chi2": chi2 / (n - len(FREE)),
        "band": list(band),
        "ljung_box": lb,
        "base": base,
    }
    failures = [f"ljung_box {k} p={v:.3g}" for k, v in lb.items() if v < 0.05]
    if not band[0] <= out["reduced_chi2"] <= band[1]:
        failures.append(f"reduced chi2 {out['reduced_chi2']:.3f} outside {band}")
    if design.effect is not None:
        chi2_aug, _, m_fit = weighted_fit(design, data, base, m)
        out.update(chi2_augmented=chi2_aug, magnitude_fit=m_fit)
        out["lrt_p"] = float(stats.chi2.sf(max(chi2 - chi2_aug, 0.0), 1))
        if not P_RANGE[0] <= out["lrt_p"] <= P_RANGE[1]:
            failures.append(f"lrt p={out['lrt_p']:.3g} outside {P_RANGE}")
    out["failures"] = failures
    return out


def experiment(run: Run, y: np.ndarray) -> Experiment:
    """The record as the CSV files lay it out (``V``, ``i``, ``w``, ``sigma_i``, ``sigma_w``)."""
    columns = {"V": run.v, **{o: y[:, k] for k, o in enumerate(OUTPUTS)}}
    columns.update({f"sigma_{o}": np.full(len(run.t), run.sigma[o]) for o in OUTPUTS})
    return experiment_from_arrays(run.name, run.t, columns)


@dataclass(frozen=True)
class UserCase:
    """A generated case: records, truth, effect, magnitude (its catalogue unit) and checks."""

    effect: str | None
    seed: int
    magnitude: float
    channel: str
    truth: dict[str, float]
    experiments: list[Experiment]
    info: dict[str, Any]


def make_case(effect: str | None, seed: int) -> UserCase:
    """A concealed case of ``effect`` (``None``: a control, nothing fitted)."""
    design = draw_design(effect, seed)
    if effect is None:
        data = noisy(design, outputs(design, design.truth, 0.0), [seed, 0, VERSION, 1])
        exps = [experiment(r, d) for r, d in zip(design.runs, data)]
        return UserCase(None, seed, 0.0, design.channel, design.truth, exps, {})
    m, lam, base = calibrate(design)
    clean = outputs(design, design.truth, m)
    rejected: list[list[str]] = []
    for attempt in range(1, ATTEMPTS + 1):
        data = noisy(design, clean, [seed, CODE[effect], VERSION, attempt])
        info = check(design, data, m, base)
        if not info["failures"] or attempt == ATTEMPTS:
            break
        rejected.append(info["failures"])
    info.update(
        target_lambda=design.target_lambda,
        achieved_lambda=lam,
        attempts=attempt,
        rejected=rejected,
        concealed=not info["failures"],
    )
    exps = [experiment(r, d) for r, d in zip(design.runs, data)]
    return UserCase(effect, seed, m, design.channel, design.truth, exps, info)


def save(case: UserCase, folder: Path) -> None:
    """Write the CSV files and ``truth.json``."""
    folder.mkdir(parents=True, exist_ok=True)
    for e in case.experiments:
        table = np.column_stack([e.time, *e.columns.values()])
        header = ",".join(["time", *e.columns])
        np.savetxt(folder / e.name, table, delimiter=",", header=header, comments="", fmt="%.17g")
    meta = {
        "version": VERSION,
        "effect": case.effect,
        "seed": case.seed,
        "magnitude": case.magnitude,
        "channel": case.channel,
        "truth": case.truth,
        "experiments": [e.name for e in case.experiments],
        "info": case.info,
    }
    (folder / "truth.json").write_text(json.dumps(meta, indent=1) + "\n")


def get_case(effect: str | None, seed: int, cache: Path | None) -> UserCase:
    """A case from the cache when made by this generator version, else made (and cached)."""
    folder = cache / f"{effect or 'control'}-{seed:04d}" if cache else None
    if folder is not None and (folder / "truth.json").is_file():
        t = json.loads((folder / "truth.json").read_text())
        if t["version"] == VERSION:
            exps = [load_experiment(folder / n) for n in t["experiments"]]
            return UserCase(
                t["effect"], t["seed"], t["magnitude"], t["channel"], t["truth"], exps, t["info"]
            )
    made = make_case(effect, seed)
    if folder is not None:
        save(made, folder)
    return made


def study_spec_json() -> str:
    """R, J, b free within :data:`FREE` from the exported values, sigma from the columns."""
    return json.dumps(
        {
            "parameters": {
                n: {"start": NOMINAL[n], "lower": lo, "upper": hi} for n, (lo, hi) in FREE.items()
            },
            "inputs": ["V"],
            "outputs": {o: {"sigma": "column"} for o in OUTPUTS},
            "global_search": False,
        }
    )


def build_fmu(folder: Path) -> Path:
    """Build the pythonfmu DC motor into ``folder`` (once; the file is reused)."""
    from pythonfmu import FmuBuilder

    fmu = folder / "DcMotor.fmu"
    if not fmu.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        source = Path(__file__).parent / "pythonfmu_src" / "dc_motor.py"
        FmuBuilder.build_FMU(source, dest=folder)
    return fmu
