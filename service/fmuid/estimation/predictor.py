"""Model predictions at the data's times: parameters + experiment -> FMU outputs."""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import Protocol

import numpy as np

from fmuid.data import Experiment
from fmuid.estimation.per_experiment import for_experiment
from fmuid.model.base import as_model
from fmuid.model.fmu import FmuModel
from fmuid.model.kept import PerObject
from fmuid.model.registry import get_simulator


class Predictor(Protocol):
    """Anything that turns parameter values and an experiment into model outputs."""

    def predict(
        self, params: Mapping[str, float], experiment: Experiment, outputs: Sequence[str]
    ) -> np.ndarray:
        """Return the outputs at every row of ``experiment.time``, shape ``(rows, outputs)``."""
        ...


def merged_inputs(
    experiment: Experiment, inputs: Sequence[str], held: Collection[str] = ()
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Put every input on the union of their sample times.

    Each input is linear between its own samples, so evaluating it at the union of all
    breakpoints reproduces it exactly as a piecewise-linear signal; an input in ``held``
    (integer, Boolean, discrete) keeps each sample's value until its next sample.

    Returns
    -------
    time, values
        Sample times [s] and the value of each input there.

    """
    if not inputs:
        return experiment.time[:1].copy(), {}
    samples = {name: experiment.input_samples(name) for name in inputs}
    time = np.unique(np.concatenate([t for t, _ in samples.values()]))
    values = {
        name: v[np.maximum(np.searchsorted(t, time, side="right") - 1, 0)]
        if name in held
        else np.interp(time, t, v)
        for name, (t, v) in samples.items()
    }
    return time, values


class FmuPredictor:
    """Simulate an FMU with the fixed parameters of a spec and the experiment's inputs.

    Parameters
    ----------
    fmu
        The parsed FMU (or its file, parsed here); each process keeps one warm instance of it
        (``get_simulator``).
    fixed
        FMU parameter values that are set in every run but not fitted.
    inputs
        Names of the FMU inputs driven from the experiments' columns.
    interface
        ``"auto"``, ``"co_simulation"`` or ``"model_exchange"`` (the spec's ``interface``);
        None: the model's.
    per_experiment
        Parameters that take one value per experiment (the spec's ``per_experiment``): an
        experiment's run takes ``name@<experiment>`` as ``name``
        (:mod:`fmuid.estimation.per_experiment`).

    """

    def __init__(
        self,
        fmu: FmuModel | str | Path,
        fixed: Mapping[str, float | str],
        inputs: Sequence[str],
        interface: str | None = None,
        per_experiment: Sequence[str] = (),
    ):
        self.model = as_model(fmu, interface)
        self.fmu_path = str(self.model.path)
        self.fixed = dict(fixed)
        self.inputs = tuple(inputs)
        self.per_experiment = tuple(per_experiment)
        self._inputs = PerObject()

    def inputs_of(self, experiment: Experiment) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Return the experiment's inputs on their merged sample times (cached)."""

        def make() -> tuple[np.ndarray, dict[str, np.ndarray]]:
            variables = self.model.inputs
            held = [n for n in self.inputs if n in variables and not variables[n].is_continuous]
            return merged_inputs(experiment, self.inputs, held)

        return self._inputs.get(experiment, make)

    def fmu_values(
        self, params: Mapping[str, float], experiment: Experiment
    ) -> dict[str, float | str]:
        """Return the FMU parameter values of ``experiment``'s run: the fixed ones, then ``params``.

        Each per-experiment parameter takes the experiment's own value, under the FMU's name.
        """
        return {**self.fixed, **for_experiment(params, self.per_experiment, experiment.name)}

    def predict(
        self, params: Mapping[str, float], experiment: Experiment, outputs: Sequence[str]
    ) -> np.ndarray:
        """Simulate the FMU and return ``outputs`` at every row of the experiment."""
        input_time, input_values = self.inputs_of(experiment)
        return get_simulator(self.model).simulate(
            self.fmu_values(params, experiment),
            input_time,
            input_values,
            experiment.time,
            list(outputs),
        )
