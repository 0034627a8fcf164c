"""The estimation problem: free parameters, their scaling, weighted residuals and chi2."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from fmuid.data import Experiment, ParameterSpec, Spec, used_inputs
from fmuid.data.checks import settled_rows
from fmuid.engine.count import counted
from fmuid.errors import DataError, FmuError
from fmuid.estimation.per_experiment import expand, split
from fmuid.estimation.predictor import FmuPredictor, Predictor
from fmuid.estimation.sigma import SPLINE_METHOD, spline_residual_sigma
from fmuid.estimation.space import ParameterSpace
from fmuid.model.fmu import FmuModel, model_of_file


class Problem:
    """Weighted least squares of FMU outputs against one or more experiments (thesis eq. 2.20).

    Parameters are fitted in the coordinates ``z`` of its :class:`ParameterSpace` (``space``):
    ``log10(value)`` for log-scaled parameters (the default when the lower bound is positive)
    and the value itself otherwise. Each simulation counts in the counts open
    (:func:`fmuid.engine.count.counting`). A parameter of ``spec.per_experiment`` is fitted as
    one parameter per experiment, ``name@<experiment>`` (:mod:`fmuid.estimation.per_experiment`),
    each with the bounds, scale and start of ``name``.

    Parameters
    ----------
    fmu_path
        The FMU file.
    experiments
        The datasets; they share the parameters.
    spec
        The study specification.
    predictor
        Computes model outputs; default simulates the FMU with ``spec.fixed`` and the inputs.
    parameters
        Free parameters, overriding ``spec.parameters`` (e.g. with added physics).
    sigma
        Per experiment, output -> per-row sigma, overriding the spec's sigma resolution.
    model
        The parsed FMU, handed on (driving ``spec.interface``); default: parsed from
        ``fmu_path``.

    """

    def __init__(
        self,
        fmu_path: str | Path,
        experiments: Sequence[Experiment],
        spec: Spec,
        *,
        predictor: Predictor | None = None,
        parameters: Mapping[str, ParameterSpec] | None = None,
        sigma: list[dict[str, np.ndarray]] | None = None,
        sigma_method: Mapping[str, str] | None = None,
        model: FmuModel | None = None,
    ):
        self.fmu_path = Path(fmu_path)
        self.model = (
            model.with_interface(spec.interface)
            if model is not None
            else model_of_file(self.fmu_path, spec.interface)
        )
        self.experiments = list(experiments)
        self.spec = spec
        params = expand(
            parameters if parameters is not None else spec.parameters,
            spec.per_experiment,
            [exp.name for exp in self.experiments],
        )
        self.parameter_specs = params
        self.space = ParameterSpace.from_specs(params)
        self.names = self.space.names
        self.scales = self.space.scales
        self.lower = self.space.lower
        self.upper = self.space.upper
        self.start = np.array([p.start for p in params.values()], dtype=float)
        self.outputs = list(spec.outputs)
        inputs = sorted(
            {
                name
                for exp in self.experiments
                for name in used_inputs(spec, list(self.model.inputs), exp)
            }
        )
        self.inputs = inputs
        self.predictor: Predictor = predictor or FmuPredictor(
            self.model, spec.fixed, inputs, per_experiment=spec.per_experiment
        )
        self.masks = [
            [
                exp.output_mask(o) & kept if o in exp.columns else np.zeros(exp.n_rows, bool)
                for o in self.outputs
            ]
            for exp in self.experiments
            for kept in [settled_rows(exp, spec.settle)]
        ]
        self.data = [
            [
                exp.columns[o][m] if o in exp.columns else np.zeros(0)
                for o, m in zip(self.outputs, ms)
            ]
            for exp, ms in zip(self.experiments, self.masks)
        ]
        if sigma is None:
            self.sigma, self.sigma_method = self._resolve_sigma()
        else:
            self.sigma = sigma
            self.sigma_method = dict(sigma_method or {o: "given" for o in self.outputs})
        self._weights = [
            [1.0 / s[o][m] for o, m in zip(self.outputs, ms)]
            for s, ms in zip(self.sigma, self.masks)
        ]
        self.n_data = int(sum(m.sum() for ms in self.masks for m in ms))
        if self.n_data == 0:
            after = f" after the {spec.settle:g} s settle window" if spec.settle else ""
            raise DataError(f"no output samples to fit in any experiment{after}")

    @property
    def n_free(self) -> int:
        """Number of free parameters."""
        return len(self.names)

    @property
    def shared_names(self) -> list[str]:
        """The free parameters every experiment shares (all but the per-experiment values)."""
        return [n for n in self.names if split(n, self.spec.per_experiment) is None]

    @property
    def z_lower(self) -> np.ndarray:
        """Lower bounds in fitted coordinates."""
        return self.space.z_lower

    @property
    def z_upper(self) -> np.ndarray:
        """Upper bounds in fitted coordinates."""
        return self.space.z_upper

    def to_z_array(self, values: np.ndarray) -> np.ndarray:
        """Map parameter values (in ``names`` order) to fitted coordinates."""
        return self.space.to_z(values)

    def to_z(self, values: Mapping[str, float]) -> np.ndarray:
        """Map a name -> value mapping of the free parameters to fitted coordinates."""
        return self.space.to_z(values)

    def from_z(self, z: np.ndarray) -> dict[str, float]:
        """Map fitted coordinates back to a name -> value mapping."""
        return self.space.from_z(z)

    def units(self) -> dict[str, str]:
        """Return the unit of each free and fixed parameter, input and output the FMU declares.

        A per-experiment parameter ``name@<experiment>`` has the unit of ``name``.
        """
        model = self.model
        declared = {**model.parameters, **model.inputs, **model.outputs}
        names = [*self.names, *self.spec.fixed, *self.inputs, *self.outputs]
        fmu_name = {n: (split(n, self.spec.per_experiment) or (n,))[0] for n in names}
        return {
            n: declared[f].unit or ""
            for n, f in fmu_name.items()
            if f in declared and declared[f].unit
        }

    def representative_sigma(self) -> dict[str, float]:
        """Return one sigma per output: the median over its fitted samples."""
        out = {}
        for j, o in enumerate(self.outputs):
            vals = np.concatenate([s[o][ms[j]] for s, ms in zip(self.sigma, self.masks)])
            out[o] = float(np.median(vals)) if vals.size else float("nan")
        return out

    def predict(self, values: Mapping[str, float]) -> list[dict[str, np.ndarray]]:
        """Return the model outputs at every row of every experiment.

        Parameters
        ----------
        values
            Free parameter values (parameter units); missing ones take their start values.

        """
        params = {n: float(v) for n, v in zip(self.names, self.start, strict=True)}
        params.update(values)
        out = []
        for exp in self.experiments:
            y = self.predictor.predict(params, exp, self.outputs)
            counted()
            out.append({o: y[:, j] for j, o in enumerate(self.outputs)})
        return out

    def simulate(
        self,
        values: Mapping[str, float],
        experiment: Experiment,
        outputs: Sequence[str] | None = None,
        predictor: Predictor | None = None,
    ) -> np.ndarray:
        """Simulate one experiment and count it; return the outputs, one column each.

        Parameters
        ----------
        values
            Parameter values handed to the predictor as they are.
        experiment
            The experiment whose inputs and times are simulated.
        outputs
            The outputs to return; default the problem's.
        predictor
            Another predictor of this problem's model (e.g. on a finer grid); default its own.

        """
        y = (predictor or self.predictor).predict(values, experiment, outputs or self.outputs)
        counted()
        return y

    def residuals(self, z: np.ndarray) -> np.ndarray:
        """Weighted residuals ``(y_data - y_model) / sigma`` of every fitted sample.

        Raises
        ------
        FmuError
            When a simulation fails or returns non-finite outputs.

        """
        values = self.from_z(np.asarray(z, dtype=float))
        parts = []
        for exp, ms, data, weights in zip(self.experiments, self.masks, self.data, self._weights):
            y = self.predictor.predict(values, exp, self.outputs)
            counted()
            for j, (m, d, w) in enumerate(zip(ms, data, weights)):
                parts.append((d - y[m, j]) * w)
        r = np.concatenate(parts)
        if not np.all(np.isfinite(r)):
            raise FmuError(
                f"{self.fmu_path.name}: non-finite outputs at {_fmt(values)}", "fmi2GetReal"
            )
        return r

    def chi2(self, z: np.ndarray) -> float:
        """Weighted sum of squared residuals at ``z``."""
        r = self.residuals(z)
        return float(r @ r)

    def _resolve_sigma(self) -> tuple[list[dict[str, np.ndarray]], dict[str, str]]:
        sigma: list[dict[str, np.ndarray]] = [{} for _ in self.experiments]
        method: dict[str, str] = {}
        for j, o in enumerate(self.outputs):
            setting = self.spec.outputs[o].sigma
            if setting == "column":
                method[o] = "column"
                for i, exp in enumerate(self.experiments):
                    col = exp.sigma_column(o)
                    if col is None and self.masks[i][j].any():
                        raise DataError(f"{exp.name}: sigma 'column' needs column 'sigma_{o}'")
                    sigma[i][o] = col if col is not None else np.ones(exp.n_rows)
            elif setting == "estimate":
                value = spline_residual_sigma(
                    [exp.time[ms[j]] for exp, ms in zip(self.experiments, self.masks)],
                    [d[j] for d in self.data],
                    o,
                    seed=self.spec.seed,
                )
                method[o] = SPLINE_METHOD
                for i, exp in enumerate(self.experiments):
                    sigma[i][o] = np.full(exp.n_rows, value)
            else:
                method[o] = "given"
                for i, exp in enumerate(self.experiments):
                    sigma[i][o] = np.full(exp.n_rows, float(setting))
        return sigma, method


def _fmt(values: Mapping[str, float]) -> str:
    return ", ".join(f"{k}={v:.6g}" for k, v in values.items())
