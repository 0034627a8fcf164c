"""An FMU predictor wrapped by effects (:mod:`.effects`): inputs changed, outputs changed, feedback.

Input effects act in their class order (offset, gain, dead zone, saturation, lag, delay) on a
fine grid that holds every input sample and data row, with no interval longer than the data's
median interval over :data:`FINE`; the FMU gets the result as a piecewise-linear input. A lag
filters exactly (the input is linear between grid points); a dead zone or a saturation clips
at the grid points. An offset or a gain alone acts on the input's own samples (the same
piecewise-linear input, with no extra points for the FMU to step to). Output lags filter the
FMU's outputs read on that fine grid (extra communication points, no spline). Feedback effects
close the loop around the FMU at the same step (:mod:`fmuid.model.feedback`). Output gains,
biases and saturations act on the data rows.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from fmuid.data import Experiment
from fmuid.discrepancy.effects import Effect, InputDelay, OutputLag
from fmuid.discrepancy.lag import first_order_lag
from fmuid.estimation.predictor import FmuPredictor
from fmuid.model.feedback import Feedback, fine_times
from fmuid.model.kept import Kept, PerObject, read_only
from fmuid.model.registry import get_simulator

FINE = 4
"""Fine-grid points per median data interval (input and output lags, clipping, feedback)."""

RECENT = 8
"""Changed inputs kept per experiment (:meth:`AugmentedPredictor._inputs`)..."""

RECENT_BYTES = 64 * 2**20
"""...within these array bytes (a long record on a refined fine grid makes arrays of tens of
megabytes; the newest is kept whatever its size)."""

T = TypeVar("T")


def fine_step(time: np.ndarray) -> float:
    """Longest fine-grid interval [s] of an experiment: its median interval over :data:`FINE`."""
    gaps = np.diff(np.asarray(time, dtype=float))
    gaps = gaps[gaps > 0]
    return float(np.median(gaps)) / FINE if gaps.size else 1.0


@dataclass
class AugmentedPredictor:
    """An FMU predictor with effects applied (any number, together).

    Parameters
    ----------
    base
        The FMU predictor of the study (fixed values, inputs).
    effects
        The effects switched on; the parameters of input, output and feedback effects are
        removed before the rest go to the FMU (declared physics' parameters go to the FMU).
    step_scale
        Multiplies the fine step (0.5 halves it: the coupling check).

    """

    base: FmuPredictor
    effects: tuple[Effect, ...]
    step_scale: float = 1.0
    _kept: PerObject = field(default_factory=PerObject, compare=False, repr=False)

    @property
    def model(self) -> object:
        """The FMU model (as the base predictor's)."""
        return self.base.model

    @property
    def wrapped(self) -> set[str]:
        """Names of the parameters the wrap consumes (not set on the FMU)."""
        return {n for e in self.effects if e.side != "fmu" for n in e.names}

    def _per_experiment(self, kind: str, experiment: Experiment, make: Callable[[], T]) -> T:
        """Return ``make()`` for an experiment, made once per process."""
        return self._kept.get(experiment, make, kind)

    def _step(self, experiment: Experiment) -> float:
        """Return the experiment's fine step [s] (:func:`fine_step` times ``step_scale``)."""
        return self._per_experiment(
            "step", experiment, lambda: fine_step(experiment.time) * self.step_scale
        )

    def _fine(self, experiment: Experiment) -> tuple[np.ndarray, np.ndarray]:
        """Fine grid holding every data row and input sample, and the rows' indices in it."""

        def make() -> tuple[np.ndarray, np.ndarray]:
            t = experiment.time
            input_time, _ = self.base.inputs_of(experiment)
            points = np.union1d(t, input_time[(input_time >= t[0]) & (input_time <= t[-1])])
            grid = fine_times(points, self._step(experiment))
            return grid, np.searchsorted(grid, t)

        return self._per_experiment("fine", experiment, make)

    def _input_grid(self, experiment: Experiment, input_time: np.ndarray) -> np.ndarray:
        """Return the fine grid joined with the input samples (kept per experiment)."""
        return self._per_experiment(
            "inputs", experiment, lambda: np.union1d(input_time, self._fine(experiment)[0])
        )

    @property
    def fine_inputs(self) -> bool:
        """Whether the inputs go to the FMU on the fine grid even when no effect changes them.

        A co-simulation FMU without input derivatives holds each input over a sub-step, with an
        error second order in the sub-step; the base model and every augmentation must cross the
        same sub-steps, or a candidate's statistic measures the change of that error. The
        simulator is told the data's input sample times, so the fine grid bounds the sub-steps
        per sample interval as the data's own samples do (it does not multiply them).
        """
        model = self.base.model
        return model.is_cosimulation and not model.can_interpolate_inputs

    def _inputs(
        self, params: Mapping[str, float], experiment: Experiment
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Return the inputs the FMU sees, on a common grid.

        The last :data:`RECENT` results are kept per experiment by the input effects' values,
        the same arrays for the same values: a finite-difference Jacobian moves the other
        parameters, and the simulator then reuses its run plan for these arrays.
        """
        input_time, inputs = self.base.inputs_of(experiment)
        acting = sorted((e for e in self.effects if e.side == "input"), key=lambda e: e.order)
        if not acting and not self.fine_inputs:
            return input_time, dict(inputs)
        recent: Kept[tuple[np.ndarray, dict[str, np.ndarray]]] = self._per_experiment(
            "recent", experiment, lambda: Kept(RECENT, RECENT_BYTES)
        )
        key = tuple(params[n] for e in acting for n in e.names)
        time, values = recent.get(
            key, lambda: self._changed(params, experiment, input_time, inputs, acting)
        )
        return time, dict(values)

    def _changed(
        self,
        params: Mapping[str, float],
        experiment: Experiment,
        input_time: np.ndarray,
        inputs: Mapping[str, np.ndarray],
        acting: list[Effect],
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Apply the input effects ``acting`` (in order) to the experiment's inputs."""
        fine = self.fine_inputs
        grid = self._input_grid(experiment, input_time)
        start = grid if fine else input_time
        times = {name: start for name in inputs}
        values = {name: np.interp(start, input_time, v) for name, v in inputs.items()}
        for e in acting:
            t, u = times[e.target], values[e.target]
            if isinstance(e, InputDelay):
                delay = e.value(params)
                times[e.target] = np.concatenate([[t[0]], t + delay])
                values[e.target] = np.concatenate([[u[0]], u])
                continue
            if t is not grid and not e.affine:
                t, u = grid, np.interp(grid, t, u)
            times[e.target], values[e.target] = t, e.on_input(t, u, params)
        if not all(t is grid for t in times.values()):
            grid = np.unique(np.concatenate(list(times.values())))
            values = {n: np.interp(grid, times[n], v) for n, v in values.items()}
        return read_only(grid), {n: read_only(v) for n, v in values.items()}

    def predict(
        self, params: Mapping[str, float], experiment: Experiment, outputs: Sequence[str]
    ) -> np.ndarray:
        """Simulate the FMU with the effects applied and return ``outputs`` at every row."""
        wrapped = self.wrapped
        fmu_params = {k: v for k, v in params.items() if k not in wrapped}
        input_time, inputs = self._inputs(params, experiment)
        terms = tuple(t for e in self.effects if e.side == "feedback" for t in e.terms(params))
        feedback = Feedback(terms, self._step(experiment)) if terms else None
        lags = [e for e in self.effects if isinstance(e, OutputLag)]
        out_time, rows = (
            self._fine(experiment) if lags else (experiment.time, np.arange(len(experiment.time)))
        )
        y = get_simulator(self.base.model).simulate(
            self.base.fmu_values(fmu_params, experiment),
            input_time,
            inputs,
            out_time,
            list(outputs),
            feedback=feedback,
            sample_time=self.base.inputs_of(experiment)[0],
        )
        y = np.array(y, dtype=float)
        names = list(outputs)
        for lag in lags:
            columns = [names.index(lag.target)] if lag.target else list(range(len(names)))
            for j in columns:
                y[:, j] = first_order_lag(out_time, y[:, j], lag.value(params))
        y = y[rows]
        for e in sorted((e for e in self.effects if e.side == "output"), key=lambda e: e.order):
            if e.target in names and not isinstance(e, OutputLag):
                j = names.index(e.target)
                y[:, j] = e.on_output(y[:, j], params)
        return y
