"""Independent field-truth generator for the diagnose tests and bench.

The tractor and single-axle implement of thesis eqs. 3.3-3.18 is written here again, from the
equations and not from the C model, and integrated with ``scipy.integrate.solve_ivp``. Each
effect that the base model leaves out is added as the physics (extra states or forces) that
produces it, never through the candidate predictors of ``fmuid.diagnose``:

============== =========================================================================
effect         how the truth makes it
============== =========================================================================
output_lag     extra states y_m' = (y - y_m) / tau for each yaw-rate channel
input_delay    the vehicle steers with delta(t - delay)
input_lag   extra actuator state delta_a' = (delta - delta_a) / tau
input_offset   the vehicle steers with delta + offset
output_bias      the recorded channel is gam + bias
tire_saturation  every lateral tire force is -C alpha_sat tanh(alpha / alpha_sat)
side_slope     m g sin(slope) cos(psi) pulls each body sideways at its CG
hitch_stiffness  (not in the catalogue) a torsional spring-damper in the hitch resists the
               articulation angle psi_t - psi_i
aligning_torque  (not in the catalogue) each tire's self-aligning moment: its lateral force
               acts a pneumatic trail behind the axle (magnitude: the trail [m])
============== =========================================================================

The recorded steer angle is logged at ``input_rate`` and the vehicle sees it interpolated
linearly, as the FMU does; yaw rates are recorded at ``rate`` with Gaussian noise of standard
deviation ``max|gam_t| / snr`` (thesis eq. 3.28), given per sample in ``sigma_<output>``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from fmuid.data.experiment import Experiment, experiment_from_arrays

G = 9.81
"""Gravity [m/s2]."""

NOMINAL = {
    "C_atf": 220000.0,
    "C_atr": 486000.0,
    "C_air": 167000.0,
    "sig_tf": 0.5,
    "sig_tr": 1.0,
    "sig_ir": 0.5,
    "m_t": 9391.0,
    "m_i": 2127.0,
    "I_tz": 35709.0,
    "I_iz": 6402.0,
    "u_tc": 4.5,
    "a": 1.7,
    "b": 1.2,
    "c": 2.1,
    "d": 3.62,
    "e": 0.1,
}
"""Thesis parameter values (contract table)."""

BOUNDS = {
    "C_atf": (10000.0, 700000.0),
    "C_atr": (10000.0, 700000.0),
    "C_air": (10000.0, 700000.0),
    "sig_tf": (0.1, 2.0),
    "sig_tr": (0.1, 2.0),
    "sig_ir": (0.1, 2.0),
}
"""Thesis Table 3.2 bounds of the six free tire parameters."""

EFFECTS = (
    "output_lag",
    "input_delay",
    "input_lag",
    "input_offset",
    "output_bias",
    "tire_saturation",
    "side_slope",
    "hitch_stiffness",
    "aligning_torque",
)

UNCATALOGUED = ("hitch_stiffness", "aligning_torque")
"""Effects that no catalogue candidate models: a right diagnosis says ``unexplained``."""

MAGNITUDES = {
    "output_lag": (0.1, 0.2),  # tau [s]
    "input_delay": (0.1, 0.2),  # delay [s]
    "input_lag": (0.1, 0.2),  # tau [s]
    "input_offset": (0.0015, 0.003),  # [rad]
    "output_bias": (0.6, 1.2),  # bias in units of the channel's noise sigma
    "tire_saturation": (0.07, 0.045),  # alpha_sat [rad]; smaller saturates more
    "side_slope": (0.06, 0.12),  # [rad]
    "hitch_stiffness": (10000.0, 20000.0),  # [N m/rad]; damping 0.3 s times it
    "aligning_torque": (0.1, 0.2),  # pneumatic trail [m]
}
"""Two magnitudes per effect: "small" (concealed) and "large"."""


@dataclass(frozen=True)
class Case:
    """One field case: truth, effect and recordings.

    Attributes
    ----------
    effect
        Effect name (``None`` for a control).
    magnitude
        The effect's size in the unit of its catalogue parameter (``output_bias``: rad/s).
    truth
        Every model parameter used.
    experiments
        The step and the chirp recordings.
    bias_output
        The biased channel for ``output_bias``.
    """

    effect: str | None
    magnitude: float
    truth: dict[str, float]
    experiments: list[Experiment]
    bias_output: str = "gam_t"
    snr: dict[str, float] = field(default_factory=dict)

    def write(self, directory: Path) -> list[Path]:
        """Write the recordings as CSV files (empty cells where a row has no sample)."""
        directory.mkdir(parents=True, exist_ok=True)
        paths = []
        for experiment in self.experiments:
            path = directory / experiment.name
            names = list(experiment.columns)
            lines = [",".join(["time", *names])]
            for i, t in enumerate(experiment.time):
                cells = [repr(float(t))]
                for name in names:
                    value = experiment.columns[name][i]
                    cells.append("" if np.isnan(value) else repr(float(value)))
                lines.append(",".join(cells))
            path.write_text("\n".join(lines) + "\n")
            paths.append(path)
        return paths


def step_steer(t: np.ndarray, amplitude: float) -> np.ndarray:
    """Rate-limited step: 0 until 1 s, ramp to ``amplitude`` [rad] over 0.5 s, hold."""
    return amplitude * np.clip((t - 1.0) / 0.5, 0.0, 1.0)


def chirp_steer(t: np.ndarray, amplitude: float, f0: float = 0.1, f1: float = 0.8) -> np.ndarray:
    """Linear chirp from ``f0`` to ``f1`` [Hz] over 1 s to the end, amplitude [rad]."""
    duration = t[-1] - 1.0
    tau = np.clip(t - 1.0, 0.0, None)
    phase = 2 * np.pi * (f0 * tau + 0.5 * (f1 - f0) * tau**2 / duration)
    return amplitude * np.sin(phase)


def simulate_truth(
    params: dict[str, float],
    input_time: np.ndarray,
    input_values: np.ndarray,
    output_time: np.ndarray,
    effect: str | None = None,
    magnitude: float = 0.0,
) -> dict[str, np.ndarray]:
    """Integrate the tractor-implement model with an effect from rest.

    Parameters
    ----------
    params
        Values of every parameter in :data:`NOMINAL`.
    input_time, input_values
        The recorded steer angle [rad], interpolated linearly (held before the first sample).
    output_time
        Times [s] at which to return the recorded yaw rates.
    effect, magnitude
        One of :data:`EFFECTS` (``output_bias`` is added by the caller) and its size.

    Returns
    -------
    dict
        ``gam_t``, ``gam_i`` [rad/s], ``psi_t``, ``psi_i`` [rad] at ``output_time``, as the
        sensors report them (after a sensor lag, if any).
    """
    p = params
    mt, mi, c, d, e, a, b, u = (p[k] for k in ("m_t", "m_i", "c", "d", "e", "a", "b", "u_tc"))
    mass = np.array(
        [
            [mt + mi, -mi * c, -mi * d],
            [-mi * c, p["I_tz"] + mi * c * c, mi * c * d],
            [-mi * d, mi * c * d, p["I_iz"] + mi * d * d],
        ]
    )
    mass_inv = np.linalg.inv(mass)
    sat = magnitude if effect == "tire_saturation" else 0.0
    slope = magnitude if effect == "side_slope" else 0.0
    k_hitch = magnitude if effect == "hitch_stiffness" else 0.0
    trail = magnitude if effect == "aligning_torque" else 0.0
    delay = magnitude if effect == "input_delay" else 0.0
    offset = magnitude if effect == "input_offset" else 0.0
    tau_delta = magnitude if effect == "input_lag" else 0.0
    tau_outputs = magnitude if effect == "output_lag" else 0.0

    def tire(stiffness: float, alpha: float) -> float:
        if sat > 0:
            return -stiffness * sat * np.tanh(alpha / sat)
        return -stiffness * alpha

    def steer(t: float) -> float:
        return float(np.interp(t - delay, input_time, input_values)) + offset

    def rhs(t: float, s: np.ndarray) -> np.ndarray:
        v, gt, gi, af, ar, ai, pt, pi = s[:8]
        delta = s[8] if tau_delta > 0 else steer(t)
        ff, fr, fi = tire(p["C_atf"], af), tire(p["C_atr"], ar), tire(p["C_air"], ai)
        gt_force = mt * G * np.sin(slope) * np.cos(pt)
        gi_force = mi * G * np.sin(slope) * np.cos(pi)
        torque = k_hitch * ((pt - pi) + 0.3 * (gt - gi))  # on the implement
        aligning = trail * (ff + fr)  # the forces act a trail behind the tractor's axles
        forces = np.array(
            [
                -(mt + mi) * u * gt + ff + fr + fi + gt_force + gi_force,
                mi * c * u * gt + a * ff - b * fr - aligning - c * fi - c * gi_force - torque,
                mi * d * u * gt - (d + e + trail) * fi - d * gi_force + torque,
            ]
        )
        acc = mass_inv @ forces
        ds = np.empty_like(s)
        ds[:3] = acc
        ds[3] = (v + a * gt - u * delta - u * af) / p["sig_tf"]
        ds[4] = (v - b * gt - u * ar) / p["sig_tr"]
        ds[5] = (v - c * gt - (d + e) * gi + u * pt - u * pi - u * ai) / p["sig_ir"]
        ds[6] = gt
        ds[7] = gi
        k = 8
        if tau_delta > 0:
            ds[8] = (steer(t) - s[8]) / tau_delta
            k = 9
        if tau_outputs > 0:
            ds[k] = (gt - s[k]) / tau_outputs
            ds[k + 1] = (gi - s[k + 1]) / tau_outputs
        return ds

    n_states = 8 + (tau_delta > 0) + 2 * (tau_outputs > 0)
    s0 = np.zeros(n_states)
    if tau_delta > 0:
        s0[8] = steer(float(output_time[0]))
    t_span = (float(min(input_time[0], output_time[0])), float(output_time[-1]))
    max_step = float(np.min(np.diff(input_time)))
    sol = solve_ivp(
        rhs,
        t_span,
        s0,
        method="LSODA",
        t_eval=output_time,
        rtol=1e-9,
        atol=1e-11,
        max_step=max_step,
    )
    if not sol.success:
        raise RuntimeError(f"field truth integration failed: {sol.message}")
    k = 8 + (tau_delta > 0)
    gam_t, gam_i = (sol.y[k], sol.y[k + 1]) if tau_outputs > 0 else (sol.y[1], sol.y[2])
    return {"gam_t": gam_t, "gam_i": gam_i, "psi_t": sol.y[6], "psi_i": sol.y[7]}


def make_case(
    effect: str | None,
    magnitude: float = 0.0,
    seed: int = 0,
    rate: float | None = None,
    snr: float | None = None,
) -> Case:
    """Make one field case: a 20 s step steer and a 30 s chirp, with an effect.

    Parameters
    ----------
    effect
        One of :data:`EFFECTS`, or ``None`` for a control without any effect.
    magnitude
        The effect's size (see :data:`MAGNITUDES`; ``output_bias`` in noise sigmas).
    seed
        Draws tire parameters off nominal (log-normal, 25%), steer amplitudes, SNR, the
        sampling rate (5 or 10 Hz), the biased channel and the noise.
    rate, snr
        Override the drawn output rate [Hz] and SNR (same for both experiments).

    Returns
    -------
    Case
        Experiments named ``step.csv`` and ``chirp.csv`` with columns ``delta``, ``gam_t``,
        ``gam_i``, ``sigma_gam_t``, ``sigma_gam_i``.
    """
    rng = np.random.default_rng(seed)
    truth = dict(NOMINAL)
    for name, (lo, hi) in BOUNDS.items():
        truth[name] = float(np.clip(NOMINAL[name] * np.exp(rng.normal(0, 0.25)), lo * 2, hi / 2))
    rate = float(rate if rate is not None else rng.choice([5.0, 10.0]))
    bias_output = str(rng.choice(["gam_t", "gam_i"]))
    input_rate = max(rate, 10.0)
    experiments = []
    snrs = {}
    bias_value = 0.0
    for name, duration in (("step.csv", 20.0), ("chirp.csv", 30.0)):
        case_snr = float(snr if snr is not None else rng.uniform(25.0, 100.0))
        t_in = np.round(np.arange(0.0, duration + 1e-9, 1.0 / input_rate), 6)
        t_out = np.round(np.arange(0.0, duration + 1e-9, 1.0 / rate), 6)
        sign = rng.choice([-1.0, 1.0])
        if name == "step.csv":
            u_in = step_steer(t_in, sign * np.deg2rad(rng.uniform(6.0, 10.0)))
        else:
            u_in = chirp_steer(t_in, sign * np.deg2rad(rng.uniform(4.0, 7.0)))
        y = simulate_truth(truth, t_in, u_in, t_out, effect, magnitude)
        sigma = float(np.max(np.abs(y["gam_t"])) / case_snr)
        if effect == "output_bias":
            bias_value = magnitude * sigma if not bias_value else bias_value
            y[bias_output] = y[bias_output] + bias_value
        noisy = {o: y[o] + rng.normal(0.0, sigma, len(t_out)) for o in ("gam_t", "gam_i")}
        experiments.append(recording(name, t_in, u_in, t_out, noisy, sigma))
        snrs[name] = case_snr
    reported = bias_value if effect == "output_bias" else magnitude
    return Case(effect, reported, truth, experiments, bias_output, snrs)


def recording(
    name: str,
    t_in: np.ndarray,
    u_in: np.ndarray,
    t_out: np.ndarray,
    outputs: dict[str, np.ndarray],
    sigma: float,
) -> Experiment:
    """Lay out one recording as the CSV files do: the union of input and output sample times.

    Parameters
    ----------
    name
        Experiment name (``step.csv``).
    t_in, u_in
        Steer samples: times [s] and angle [rad] (column ``delta``).
    t_out, outputs
        Output sample times [s] and the recorded ``gam_t``, ``gam_i`` [rad/s] there.
    sigma
        Noise standard deviation [rad/s], written per sample in ``sigma_<output>``.

    Returns
    -------
    Experiment
        Empty cells (NaN) where a row has no sample of a column.
    """
    rows = np.union1d(t_in, t_out)
    out_rows = np.isin(rows, t_out)
    columns = {"delta": np.interp(rows, t_in, u_in)}
    columns["delta"][~np.isin(rows, t_in)] = np.nan
    for output, values in outputs.items():
        col = np.full(len(rows), np.nan)
        col[out_rows] = values
        columns[output] = col
        sig = np.full(len(rows), np.nan)
        sig[out_rows] = sigma
        columns[f"sigma_{output}"] = sig
    return experiment_from_arrays(name, rows, columns)
