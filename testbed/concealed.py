"""Concealed field-truth cases: each effect sized per case so that the base fit hides it.

A case is drawn as in :func:`fieldtruth.make_case` (tire parameters log-normal 25 % off nominal,
drawn again when within a factor 2 of the lower or 1.25 of the upper bound; SNR 25-100 per
experiment, 5 or 10 Hz, a step steer and a chirp; the noise sigma is ``max|gam_t| / SNR`` of
the motion without the effect, so that it does not move with the magnitude) plus a target
noncentrality ``lambda`` (log-uniform in :data:`LAMBDA_RANGE`). The effect's magnitude is found
by a safeguarded secant search (bisection when the secant leaves the bracket) in log-log space on

    lambda(m) = min chi2 of the BASE model fitted to the noise-free data with the effect,

weighted with the case's sigma. Then noise is added and the operational criteria of
:mod:`operational` are checked on the noisy data (Ljung-Box on every channel, reduced chi2 in
the noise band, likelihood-ratio p of the true augmentation in [1e-12, 1e-3]; for the effects
of ``fieldtruth.UNCATALOGUED`` only the first two). When they fail, the noise is drawn again
(up to :data:`ATTEMPTS` times); a case that stays visible is kept with ``concealed = False``.

Controls use the same draw without an effect and without any fit. Cases are cached on disk as
the CSV files plus ``truth.json``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import fieldtruth as ft
from fmuid.data import Experiment, load_experiment
from operational import base_fit, check_case

VERSION = 2
"""Bumped when the generator changes; cached cases of another version are made again."""
LAMBDA_RANGE = (15.0, 45.0)
ATTEMPTS = 10
"""Noise draws tried per case before it is reported as not concealable."""
MAX_SEARCH = 10
"""Base fits spent on the magnitude search."""
TOLERANCE = 1.1
"""The search stops when lambda is within this factor of the target."""
CODE: dict[str | None, int] = {None: 0, **{e: i + 1 for i, e in enumerate(ft.EFFECTS)}}
"""Per-effect stream of the random draws (``None``: controls)."""
FIRST_STRENGTH = {
    "output_lag": 0.05,
    "input_delay": 0.05,
    "input_lag": 0.05,
    "input_offset": 0.001,
    "output_bias": 0.001,
    "tire_saturation": 10.0,
    "side_slope": 0.03,
    "hitch_stiffness": 5000.0,
    "aligning_torque": 0.05,
}
"""Where the search starts (strength units: see :func:`magnitude_of`)."""
STRENGTH_RANGE = {
    "output_lag": (1e-4, 1.0),
    "input_delay": (1e-4, 1.0),
    "input_lag": (1e-4, 1.0),
    "input_offset": (1e-6, 0.1),
    "output_bias": (1e-6, 0.1),
    "tire_saturation": (0.5, 500.0),
    "side_slope": (1e-5, 0.5),
    "hitch_stiffness": (1.0, 1e6),
    "aligning_torque": (1e-4, 2.0),
}
SIGNED = ("input_offset", "output_bias", "side_slope")


@dataclass(frozen=True)
class Design:
    """Everything of a case but the effect's magnitude and the noise.

    Attributes
    ----------
    effect, seed
        The effect (``None``: control) and the case's seed.
    truth
        Every model parameter (tires off nominal).
    runs
        Per experiment: name, steer times and values, output times, sigma [rad/s], SNR.
    bias_output, sign
        The biased channel (``output_bias``) and the sign of a signed effect.
    target_lambda
        Noncentrality the magnitude is sized for.
    """

    effect: str | None
    seed: int
    truth: dict[str, float]
    runs: tuple[tuple[str, np.ndarray, np.ndarray, np.ndarray, float, float], ...]
    bias_output: str
    sign: float
    target_lambda: float


@dataclass(frozen=True)
class ConcealedCase:
    """A generated case with what was checked about it.

    Attributes
    ----------
    case
        The recordings and truth (``case.magnitude`` in the catalogue parameter's unit).
    seed, target_lambda, achieved_lambda
        The seed; the lambda aimed at and the one reached on noise-free data.
    attempts
        Noise draws made.
    check
        The operational criteria on the kept noisy data (``None`` for controls).
    concealed
        Whether every criterion holds.
    """

    case: ft.Case
    seed: int
    target_lambda: float = 0.0
    achieved_lambda: float = 0.0
    attempts: int = 0
    check: dict[str, Any] = field(default_factory=dict)
    concealed: bool = False


def magnitude_of(effect: str, strength: float, sign: float) -> float:
    """Effect parameter for a search strength: 1/alpha_sat for saturation, signed for offsets."""
    if effect == "tire_saturation":
        return 1.0 / strength
    return sign * strength if effect in SIGNED else strength


def draw_design(effect: str | None, seed: int) -> Design:
    """Draw tires, rate, SNR, steer amplitudes, channel, sign and target lambda of a case."""
    rng = np.random.default_rng([seed, CODE[effect], VERSION])
    truth = dict(ft.NOMINAL)
    for name, (lo, hi) in ft.BOUNDS.items():
        value = 0.0
        while not 2 * lo <= value <= hi / 1.25:  # make_case's clip at hi / 2 pins C_atr
            value = ft.NOMINAL[name] * float(np.exp(rng.normal(0, 0.25)))
        truth[name] = value
    rate = float(rng.choice([5.0, 10.0]))
    bias_output = str(rng.choice(["gam_t", "gam_i"]))
    sign = float(rng.choice([-1.0, 1.0]))
    target = float(np.exp(rng.uniform(*np.log(LAMBDA_RANGE))))
    runs = []
    for name, duration in (("step.csv", 20.0), ("chirp.csv", 30.0)):
        snr = float(rng.uniform(25.0, 100.0))
        t_in = np.round(np.arange(0.0, duration + 1e-9, 1.0 / max(rate, 10.0)), 6)
        t_out = np.round(np.arange(0.0, duration + 1e-9, 1.0 / rate), 6)
        steer_sign = rng.choice([-1.0, 1.0])
        if name == "step.csv":
            u_in = ft.step_steer(t_in, steer_sign * np.deg2rad(rng.uniform(6.0, 10.0)))
        else:
            u_in = ft.chirp_steer(t_in, steer_sign * np.deg2rad(rng.uniform(4.0, 7.0)))
        y = ft.simulate_truth(truth, t_in, u_in, t_out)
        runs.append((name, t_in, u_in, t_out, float(np.max(np.abs(y["gam_t"])) / snr), snr))
    return Design(effect, seed, truth, tuple(runs), bias_output, sign, target)


def recordings(design: Design, magnitude: float, noise: tuple[int, ...] | None) -> list[Experiment]:
    """Simulate the design's experiments with the effect; add noise drawn from seed ``noise``."""
    rng = np.random.default_rng(list(noise)) if noise is not None else None
    out = []
    for name, t_in, u_in, t_out, sigma, _ in design.runs:
        effect = design.effect if design.effect != "output_bias" else None
        y = ft.simulate_truth(design.truth, t_in, u_in, t_out, effect, magnitude)
        if design.effect == "output_bias":
            y[design.bias_output] = y[design.bias_output] + magnitude
        outputs = {o: y[o] for o in ("gam_t", "gam_i")}
        if rng is not None:
            outputs = {o: v + rng.normal(0.0, sigma, len(v)) for o, v in outputs.items()}
        out.append(ft.recording(name, t_in, u_in, t_out, outputs, sigma))
    return out


def tires(values: Mapping[str, float]) -> dict[str, float]:
    """The six free tire parameters of a parameter mapping."""
    return {n: float(values[n]) for n in ft.BOUNDS}


def calibrate(design: Design) -> tuple[float, float, dict[str, float]]:
    """Find the magnitude whose noise-free base-fit chi2 is the target lambda.

    Returns
    -------
    magnitude, lambda, estimates
        The effect parameter, the lambda reached and the base fit's tires there.
    """
    effect = str(design.effect)
    target, lo_s, hi_s = design.target_lambda, *STRENGTH_RANGE[effect]
    below: tuple[float, float] | None = None
    above: tuple[float, float] | None = None
    s, slope = FIRST_STRENGTH[effect], 2.0
    start = tires(design.truth)
    best = (math.inf, 0.0, 0.0, start)
    for _ in range(MAX_SEARCH):
        m = magnitude_of(effect, s, design.sign)
        _, fit = base_fit(recordings(design, m, None), [tires(design.truth), start])
        lam, start = max(float(fit.chi2), 1e-12), tires(fit.estimates)
        gap = abs(math.log(lam / target))
        if gap < best[0]:
            best = (gap, m, lam, start)
        if gap < math.log(TOLERANCE):
            break
        if lam < target:
            below = (s, lam)
        else:
            above = (s, lam)
        if below and above:
            slope = math.log(above[1] / below[1]) / math.log(above[0] / below[0])
            slope = min(max(slope, 0.5), 6.0)
            s_new = below[0] * (target / below[1]) ** (1.0 / slope)
            if not min(below[0], above[0]) < s_new < max(below[0], above[0]):
                s_new = math.sqrt(below[0] * above[0])
        else:
            s_new = s * min(max((target / lam) ** (1.0 / slope), 0.1), 10.0)
        s = min(max(s_new, lo_s), hi_s)
    return best[1], best[2], best[3]


def concealed_case(effect: str, seed: int) -> ConcealedCase:
    """Make one concealed case of ``effect`` (see the module docstring).

    The kept draw's ``check`` lists under ``rejected`` why the earlier noise draws failed.
    """
    design = draw_design(effect, seed)
    magnitude, lam, estimates = calibrate(design)
    rejected: list[list[str]] = []
    for attempt in range(1, ATTEMPTS + 1):
        experiments = recordings(design, magnitude, (seed, CODE[effect], VERSION, attempt))
        starts = [estimates, tires(design.truth)]
        check = check_case(experiments, effect, magnitude, starts, design.bias_output)
        failures = check.failures()
        if not failures or attempt == ATTEMPTS:
            break
        rejected.append(failures)
    case = make_ft_case(design, magnitude, experiments)
    summary = {**check.to_dict(), "rejected": rejected}
    return ConcealedCase(case, seed, design.target_lambda, lam, attempt, summary, not failures)


def control_case(seed: int) -> ConcealedCase:
    """A control: the same draw without an effect, noise added, nothing fitted."""
    design = draw_design(None, seed)
    experiments = recordings(design, 0.0, (seed, CODE[None], VERSION, 1))
    return ConcealedCase(make_ft_case(design, 0.0, experiments), seed, attempts=1)


def make_ft_case(design: Design, magnitude: float, experiments: list[Experiment]) -> ft.Case:
    """Wrap recordings as a :class:`fieldtruth.Case`."""
    snr = {run[0]: run[5] for run in design.runs}
    return ft.Case(design.effect, magnitude, design.truth, experiments, design.bias_output, snr)


def save(case: ConcealedCase, directory: Path) -> None:
    """Write the CSV files and ``truth.json`` into ``directory``."""
    case.case.write(directory)
    truth = {
        "version": VERSION,
        "effect": case.case.effect,
        "seed": case.seed,
        "magnitude": case.case.magnitude,
        "truth": case.case.truth,
        "bias_output": case.case.bias_output,
        "snr": case.case.snr,
        "experiments": [e.name for e in case.case.experiments],
        "target_lambda": case.target_lambda,
        "achieved_lambda": case.achieved_lambda,
        "attempts": case.attempts,
        "concealed": case.concealed,
        "check": case.check,
    }
    (directory / "truth.json").write_text(json.dumps(truth, indent=1) + "\n")


def load(directory: Path) -> ConcealedCase | None:
    """Read a cached case, or ``None`` when absent or made by another generator version."""
    path = directory / "truth.json"
    if not path.is_file():
        return None
    t = json.loads(path.read_text())
    if t.get("version") != VERSION:
        return None
    experiments = [load_experiment(directory / name) for name in t["experiments"]]
    case = ft.Case(t["effect"], t["magnitude"], t["truth"], experiments, t["bias_output"], t["snr"])
    return ConcealedCase(
        case,
        t["seed"],
        t["target_lambda"],
        t["achieved_lambda"],
        t["attempts"],
        t["check"],
        t["concealed"],
    )


def get_case(effect: str | None, seed: int, cache: Path | None = None) -> ConcealedCase:
    """A concealed case (or a control when ``effect`` is ``None``), from the cache if there."""
    folder = cache / f"{effect or 'control'}-{seed:04d}" if cache is not None else None
    cached = load(folder) if folder is not None else None
    if cached is not None:
        return cached
    made = control_case(seed) if effect is None else concealed_case(effect, seed)
    if folder is not None:
        save(made, folder)
    return made
