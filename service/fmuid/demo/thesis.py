"""The thesis study's constants and data (section 3.2.3.1): tables, designs, noise levels.

Thesis Table 3.2 (nominal tire parameters and their bounds), Table 3.3 (the reference intervals),
the three experiment designs (rate-limited step ``ramp`` at 5 and 10 Hz, ``chirp`` at 5 Hz, 10 s
each), the six SNR levels with ``sigma = max|gam_t| / SNR`` (thesis eq. 3.28), and the simulated
datasets and spec of the study. Tests and benches take the thesis numbers from here.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fmuid.data import Experiment, Spec, experiment_from_arrays, spec_from_json
from fmuid.estimation.predictor import FmuPredictor
from fmuid.model.fmu import FmuModel
from fmuid.profiling.result import ProfileResult

MODEL = "tractor_implement"
OUTPUTS = ("gam_t", "gam_i")
DURATION = 10.0
"""Length of every experiment [s]."""
STEER = 0.17452
"""Ramp steer angle after 1.5 s [rad] (10 degrees)."""
CHIRP_AMPLITUDE = 0.17453
"""Chirp steer amplitude [rad]."""

NOMINAL = {
    "C_atf": 220000.0,
    "C_atr": 486000.0,
    "C_air": 167000.0,
    "sig_tf": 0.5,
    "sig_tr": 1.0,
    "sig_ir": 0.5,
}
"""True (nominal) tire parameters, thesis Table 3.2 [N/rad, m]."""

BOUNDS = {
    "C_atf": (10000.0, 700000.0),
    "C_atr": (10000.0, 700000.0),
    "C_air": (10000.0, 700000.0),
    "sig_tf": (0.1, 2.0),
    "sig_tr": (0.1, 2.0),
    "sig_ir": (0.1, 2.0),
}
"""Bounds of thesis Table 3.2."""

UNITS = {
    "C_atf": "N/rad",
    "C_atr": "N/rad",
    "C_air": "N/rad",
    "sig_tf": "m",
    "sig_tr": "m",
    "sig_ir": "m",
}

THESIS_TABLE_3_3 = {
    "C_atf": (219700.0, 218600.0, 220800.0),
    "C_atr": (485400.0, 481400.0, 489200.0),
    "C_air": (169000.0, 162700.0, 175900.0),
    "sig_tf": (0.500, 0.486, 0.513),
    "sig_tr": (0.990, 0.969, 1.010),
    "sig_ir": (0.591, 0.510, 0.667),
}
"""Thesis Table 3.3 (ramp 5 Hz, SNR 1000): estimate, 68% simultaneous CI lower and upper."""

COMPILATION_GROUPS = {
    "Tire cornering stiffnesses": ("C_atf", "C_atr", "C_air"),
    "Tire relaxation lengths": ("sig_tf", "sig_tr", "sig_ir"),
}
"""Parameters of the compilations across designs (thesis Figs 3.9 and 3.10)."""

SNRS = (1000.0, 100.0, 50.0, 25.0, 16.67, 12.5)
"""Signal-to-noise ratios of thesis section 3.2.3.1.1."""


@dataclass(frozen=True)
class Design:
    """One experiment design: steer input and output sampling rate.

    Attributes
    ----------
    name
        Label, e.g. ``"ramp 5 Hz"``.
    kind
        ``"ramp"`` (0 until 1.0 s, linear to 10 degrees at 1.5 s, then held) or ``"chirp"``
        (``0.17453 sin(2 pi (0.1 t + 0.02 t^2))``, 0.1 to 0.5 Hz, sampled every 0.1 s).
    rate_hz
        Output sampling rate [Hz].

    """

    name: str
    kind: str
    rate_hz: float

    @property
    def slug(self) -> str:
        """File-name form of the name."""
        return self.name.replace(" ", "_")


DESIGNS = (
    Design("ramp 5 Hz", "ramp", 5.0),
    Design("ramp 10 Hz", "ramp", 10.0),
    Design("chirp 5 Hz", "chirp", 5.0),
)
GRIDS = {
    "full": (DESIGNS, SNRS),
    "small": ((DESIGNS[0], DESIGNS[2]), (1000.0, 25.0)),
}
"""Designs and SNR levels of each grid."""


@dataclass(frozen=True)
class DatasetRun:
    """One simulated dataset and its profile study.

    Attributes
    ----------
    design, snr
        How the data were made.
    sigma
        Noise standard deviation of both yaw rates [rad/s].
    experiment, spec
        The dataset and the study specification.
    result
        The profile study.
    seconds
        Wall time of the profile study [s].

    """

    design: Design
    snr: float
    sigma: float
    experiment: Experiment
    spec: Spec
    result: ProfileResult
    seconds: float


def steer_samples(design: Design) -> tuple[np.ndarray, np.ndarray]:
    """Return the steer input samples (times [s], angles [rad]) of a design."""
    if design.kind == "ramp":
        return np.array([0.0, 1.0, 1.5, DURATION]), np.array([0.0, 0.0, STEER, STEER])
    t = np.round(np.arange(int(round(DURATION / 0.1)) + 1) * 0.1, 10)
    return t, CHIRP_AMPLITUDE * np.sin(2.0 * np.pi * (0.1 * t + 0.02 * t**2))


def simulate_dataset(
    fmu: Path | FmuModel, design: Design, snr: float, rng: np.random.Generator
) -> tuple[Experiment, float]:
    """Simulate a design at the nominal parameters and add noise at ``snr``.

    Parameters
    ----------
    fmu
        The tractor-implement FMU (parsed, or its file).
    design
        Steer input and sampling rate.
    snr
        Signal-to-noise ratio, ``max|gam_t| / sigma`` (thesis eq. 3.28).
    rng
        Source of the noise.

    Returns
    -------
    tuple
        The experiment (rows at the union of input and output times; outputs empty in rows
        that only carry an input sample) and the noise sigma [rad/s].

    """
    t_in, steer = steer_samples(design)
    n_out = int(round(DURATION * design.rate_hz))
    t_out = np.round(np.arange(n_out + 1) / design.rate_hz, 10)
    time_rows = np.unique(np.concatenate([t_in, t_out]))
    delta = np.interp(time_rows, t_in, steer)
    is_out = np.isin(time_rows, t_out)
    name = f"{design.slug}_snr{snr:g}.csv"
    clean_exp = experiment_from_arrays(name, time_rows, {"delta": delta})
    clean = FmuPredictor(fmu, {}, ["delta"]).predict(NOMINAL, clean_exp, list(OUTPUTS))
    sigma = float(np.max(np.abs(clean[is_out, 0])) / snr)
    columns = {"delta": delta}
    for j, output in enumerate(OUTPUTS):
        noisy = clean[:, j] + rng.normal(0.0, sigma, size=len(time_rows))
        columns[output] = np.where(is_out, noisy, np.nan)
    return experiment_from_arrays(name, time_rows, columns), sigma


def study_spec(sigma: float) -> Spec:
    """Return the spec of the study: six tire parameters from nominal, given sigma."""
    doc = {
        "parameters": {
            n: {"start": NOMINAL[n], "lower": BOUNDS[n][0], "upper": BOUNDS[n][1]} for n in NOMINAL
        },
        "inputs": ["delta"],
        "outputs": {o: {"sigma": sigma} for o in OUTPUTS},
        "confidence": 0.68,
        "global_search": False,
        "seed": 0,
    }
    return spec_from_json(json.dumps(doc), source="demo spec")
