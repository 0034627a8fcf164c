"""Generic effects as wrappers around any FMU predictor: they act on its inputs or its outputs.

The diagnose catalogue's generic candidates and the design's hypotheses are built on them.

Input effects apply in the order offset, lag, delay; output effects in the order lag, bias.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter

from fmuid.data import Experiment
from fmuid.estimation.predictor import FmuPredictor
from fmuid.model.registry import get_simulator

INPUT_STEP = 0.02
"""Grid step [s] of a lagged input handed to the FMU (at most half the data's interval)."""

FILTER_STEP = 0.005
"""Grid step [s] on which a sensor lag filters the outputs, interpolated there by a cubic
spline through the FMU's own step times (no extra FMU steps)."""


FINEST = 20
"""A fine grid is at most this many times finer than its nominal step, however close two data
rows lie (rows nearer than that are still on the grid; nothing in between them is)."""


def first_order_lag(time: np.ndarray, values: np.ndarray, tau: float) -> np.ndarray:
    """Exact first-order lag ``y' = (u - y) / tau`` of a piecewise-linear ``u``, from rest at u[0].

    Parameters
    ----------
    time
        Sample times [s], increasing.
    values
        Samples of ``u`` (first axis along time); ``u`` is linear between them.
    tau
        Time constant [s], > 0.

    """
    h = np.diff(time)
    u = np.asarray(values, dtype=float)
    if len(h) and np.allclose(h, h[0], rtol=1e-6):
        a = float(np.exp(-h[0] / tau))
        b0 = 1.0 - tau / h[0] * (1.0 - a)
        return u[0] + lfilter([b0, 1.0 - a - b0], [1.0, -a], u - u[0], axis=0)
    a_k = np.exp(-h / tau)
    ramp = 1.0 - tau / h * (1.0 - a_k)
    y = np.empty_like(u)
    y[0] = u[0]
    for k in range(len(h)):
        y[k + 1] = a_k[k] * y[k] + (1.0 - a_k[k]) * u[k] + ramp[k] * (u[k + 1] - u[k])
    return y


@dataclass
class AugmentedPredictor:
    """An FMU predictor wrapped by generic candidates (any number, applied together).

    Input effects apply in the order offset, lag, delay; output effects in the order lag, bias.
    Parameters of the wrappers are removed before the rest go to the FMU.

    Parameters
    ----------
    base
        The FMU predictor of the study (fixed values, inputs).
    wrappers
        ``{parameter name: (kind, input or output)}`` of the generic candidates switched on.

    """

    base: FmuPredictor
    wrappers: dict[str, tuple[str, str | None]]
    _grids: dict[tuple[int, float], tuple[Experiment, np.ndarray, np.ndarray]] = field(
        default_factory=dict
    )

    def __getstate__(self) -> dict[str, object]:
        """Pickle without the per-process grid cache."""
        return {"base": self.base, "wrappers": self.wrappers, "_grids": {}}

    def _fine(self, experiment: Experiment, step: float) -> tuple[np.ndarray, np.ndarray]:
        """Time grid of about ``step`` holding every data row, and the rows' indices in it."""
        key = (id(experiment), step)
        cached = self._grids.get(key)
        if cached is None or cached[0] is not experiment:
            t = experiment.time
            step = max(min(step, float(np.min(np.diff(t))) / 2), step / FINEST)
            fine = np.arange(t[0], t[-1], step)
            index = np.searchsorted(t, fine)
            near = np.minimum(
                np.abs(fine - t[np.clip(index, 0, len(t) - 1)]),
                np.abs(fine - t[np.clip(index - 1, 0, None)]),
            )
            grid = np.union1d(t, fine[near > 1e-3 * step])
            cached = (experiment, grid, np.searchsorted(grid, t))
            self._grids[key] = cached
        return cached[1], cached[2]

    def predict(
        self, params: Mapping[str, float], experiment: Experiment, outputs: Sequence[str]
    ) -> np.ndarray:
        """Simulate the FMU with the wrappers applied and return ``outputs`` at every row."""
        fmu_params = {k: v for k, v in params.items() if k not in self.wrappers}
        by_kind: dict[str, list[tuple[str, float]]] = {}
        for name, (kind, target) in self.wrappers.items():
            by_kind.setdefault(kind, []).append((target or "", float(params[name])))
        input_time, inputs = self.base.inputs_of(experiment)
        times = {name: input_time for name in inputs}
        values = {name: np.asarray(v, dtype=float) for name, v in inputs.items()}
        for target, offset in by_kind.get("steer_offset", []):
            values[target] = values[target] + offset
        for target, tau in by_kind.get("steering_lag", []):
            fine = np.union1d(times[target], self._fine(experiment, INPUT_STEP)[0])
            dense = np.interp(fine, times[target], values[target])
            values[target] = first_order_lag(fine, dense, tau)
            times[target] = fine
        for target, delay in by_kind.get("input_delay", []):
            t0 = times[target][0]
            times[target] = np.concatenate([[t0], times[target] + delay])
            values[target] = np.concatenate([[values[target][0]], values[target]])
        if len(inputs) > 1 or any(k in by_kind for k in ("steering_lag", "input_delay")):
            common = np.unique(np.concatenate(list(times.values())))
            values = {n: np.interp(common, times[n], v) for n, v in values.items()}
        else:
            common = next(iter(times.values()), input_time)
        lag = by_kind.get("sensor_lag", [])
        # the FMU steps over the input and output times anyway: read the outputs at all of
        # them, interpolate by a cubic spline onto the fine grid and filter there
        out_time = np.union1d(experiment.time, common[common <= experiment.time[-1]])
        out_time = out_time if lag else experiment.time
        y = get_simulator(self.base.model).simulate(
            {**self.base.fixed, **fmu_params}, common, values, out_time, list(outputs)
        )
        y = np.array(y, dtype=float)
        if lag:
            grid, rows = self._fine(experiment, FILTER_STEP)
            dense = CubicSpline(out_time, y, axis=0)(grid)
            y = first_order_lag(grid, dense, lag[0][1])[rows]
        for target, bias in by_kind.get("gyro_bias", []):
            if target in outputs:
                y[:, list(outputs).index(target)] += bias
        return y
