"""Test designs (``Trial``): the input signal of each family, the sampled experiment, sampling.

Families (all start from rest at 0; the input is linear between its samples):

- ``step``: 0 until ``time``, then ``amplitude`` (a 20 ms rise).
- ``ramp``: the thesis's manoeuvre: 0 until ``start``, linear to ``amplitude`` over ``rise``.
- ``chirp``: ``amplitude sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))``, linear sweep over the test.
- ``multisine``: ``tones`` sines spread logarithmically over ``[f_min, f_max]``, Schroeder
  phases, faded in by a raised cosine over one period of ``f_min`` (at most a quarter of the
  test), scaled to peak ``amplitude``.
- ``double_lane_change``: from 1 s, one sine period of length ``duration`` (lane change),
  straight for ``duration``, then the mirrored period back.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from fmuid.data import Experiment, experiment_from_arrays
from fmuid.experiment_design.space import FAMILY_SETTINGS, Space

STEP_RISE = 0.02
"""Rise time of a ``step`` [s]."""
DLC_START = 1.0
"""Start of a double lane change [s]."""


@dataclass(frozen=True)
class Trial:
    """One test design: input family and settings, duration, rate, sensors, test parameters.

    Attributes
    ----------
    family
        Input family (see :data:`fmuid.experiment_design.space.FAMILY_SETTINGS`).
    settings
        Values of the family's settings.
    duration
        Test length [s].
    rate_hz
        Sampling rate of the sensors [Hz].
    outputs
        Measured FMU outputs.
    fixed
        FMU parameters the test sets.

    """

    family: str
    settings: Mapping[str, float]
    duration: float
    rate_hz: float
    outputs: tuple[str, ...]
    fixed: Mapping[str, float] = field(default_factory=dict)

    def with_(self, **changes: object) -> Trial:
        """Return a copy with some fields changed."""
        values = {**self.__dict__, **changes}
        return Trial(**values)  # type: ignore[arg-type]

    @property
    def label(self) -> str:
        """Short human-readable name."""
        s = ", ".join(f"{k} {v:.3g}" for k, v in self.settings.items())
        return f"{self.family} ({s}), {self.duration:.3g} s at {self.rate_hz:g} Hz"


def trial_from_dict(d: Mapping[str, object]) -> Trial:
    """Inverse of :meth:`Trial.to_dict`."""
    return Trial(
        family=str(d["input"]),
        settings=dict(d["settings"]),  # type: ignore[call-overload]
        duration=float(d["duration"]),  # type: ignore[arg-type]
        rate_hz=float(d["rate_hz"]),  # type: ignore[arg-type]
        outputs=tuple(d["outputs"]),  # type: ignore[arg-type]
        fixed=dict(d.get("fixed") or {}),  # type: ignore[call-overload]
    )


def input_signal(trial: Trial) -> tuple[np.ndarray, np.ndarray]:
    """Return the input's samples (times [s], values) of a trial; linear in between."""
    s, T = trial.settings, trial.duration
    a = float(s.get("amplitude", 0.0))
    if trial.family == "step":
        t0 = min(float(s["time"]), T - STEP_RISE)
        return np.array([0.0, t0, t0 + STEP_RISE, T]), np.array([0.0, 0.0, a, a])
    if trial.family == "ramp":
        t0 = min(float(s["start"]), T)
        t1 = min(t0 + float(s["rise"]), T)
        return np.unique([0.0, t0, t1, T]), np.interp(np.unique([0.0, t0, t1, T]), [t0, t1], [0, a])
    if trial.family == "chirp":
        f0, f1 = float(s["f0"]), float(s["f1"])
        t = _grid(T, max(f0, f1))
        return t, a * np.sin(2.0 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2.0 * T)))
    if trial.family == "multisine":
        n = max(1, int(round(float(s["tones"]))))
        freqs = np.geomspace(float(s["f_min"]), max(float(s["f_max"]), float(s["f_min"])), n)
        t = _grid(T, float(freqs[-1]))
        phases = -np.pi * np.arange(n) * (np.arange(n) + 1) / n
        u = np.sin(2.0 * np.pi * freqs[:, None] * t[None, :] + phases[:, None]).sum(axis=0)
        fade = min(1.0 / float(freqs[0]), T / 4.0)
        u *= np.where(t < fade, 0.5 * (1.0 - np.cos(np.pi * t / fade)), 1.0)
        return t, a * u / max(float(np.max(np.abs(u))), 1e-12)
    if trial.family == "double_lane_change":
        d = float(s["duration"])
        t = _grid(T, 1.0 / d)
        x = (t - DLC_START) / d
        u = np.where((x >= 0) & (x <= 1), np.sin(2 * np.pi * x), 0.0)
        u -= np.where((x >= 2) & (x <= 3), np.sin(2 * np.pi * (x - 2)), 0.0)
        return t, a * u
    raise ValueError(f"unknown input family {trial.family!r}")


def _grid(duration: float, f_max: float) -> np.ndarray:
    """Input sample times: at least 20 per period of ``f_max`` and every 0.05 s.

    Rounded as :func:`output_times` rounds, so that a shared instant is one row.
    """
    step = min(0.05, 1.0 / (20.0 * f_max))
    n = int(math.ceil(duration / step))
    return np.round(np.linspace(0.0, duration, n + 1), 10)


def output_times(trial: Trial) -> np.ndarray:
    """Sample times of the sensors [s]: from 0 every ``1/rate_hz`` to the end."""
    n = int(math.floor(trial.duration * trial.rate_hz + 1e-9))
    return np.round(np.arange(n + 1) / trial.rate_hz, 10)


def trial_experiment(
    trial: Trial, input_name: str, values: Mapping[str, np.ndarray] | None = None
) -> Experiment:
    """Build the experiment of a trial: rows at input and sensor times.

    Parameters
    ----------
    trial
        The design.
    input_name
        The FMU input the signal drives.
    values
        Output -> values at the sensor times (default zeros: a template for sensitivities).

    """
    t_in, u = input_signal(trial)
    t_out = output_times(trial)
    rows = np.unique(np.concatenate([t_in, t_out]))
    is_out = np.isin(rows, t_out)
    columns = {input_name: np.interp(rows, t_in, u)}
    for o in trial.outputs:
        col = np.full(len(rows), np.nan)
        col[is_out] = values[o] if values is not None else 0.0
        columns[o] = col
    return experiment_from_arrays(f"{trial.family}.csv", rows, columns)


def sample_trials(space: Space, rng: np.random.Generator) -> list[Trial]:
    """Latin-hypercube sample of ``space.candidates`` designs per family, every rate.

    Sensor sets are not sampled: the screen scores every set of a sampled design.
    """
    out = []
    for family, ranges in space.families.items():
        names = list(FAMILY_SETTINGS[family])
        dims = [*(ranges[n] for n in names), space.duration, *space.fixed.values()]
        n = space.candidates
        strata = (
            rng.permuted(np.tile(np.arange(n), (len(dims), 1)), axis=1).T
            + rng.random((n, len(dims)))
        ) / n
        for row in strata:
            vals = [lo + (hi - lo) * x for (lo, hi), x in zip(dims, row, strict=True)]
            settings = dict(zip(names, vals[: len(names)], strict=True))
            if family == "multisine":
                settings["tones"] = float(round(settings["tones"]))
            duration = float(vals[len(names)])
            if family == "double_lane_change":
                duration = max(
                    duration, min(DLC_START + 3 * settings["duration"], space.duration[1])
                )
                settings["duration"] = min(settings["duration"], (duration - DLC_START) / 3)
            fixed = dict(zip(space.fixed, vals[len(names) + 1 :], strict=True))
            for rate in space.rates_hz:
                out.append(
                    Trial(family, settings, duration, float(rate), tuple(space.outputs), fixed)
                )
    return out
