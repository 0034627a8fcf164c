"""Fisher information of a test design through the FMU, and what it predicts.

Sensitivities are central finite differences of the weighted outputs ``y / sigma`` in the fitted
coordinates ``z`` (log10 for log-scaled parameters), taken by the fit's own Jacobian
(:func:`fmuid.estimation.optimize.jacobian`). The information ``F = J^T J`` predicts the
likelihood-based interval of each parameter as ``z_hat +- sqrt(threshold * (F^-1)_ii)`` with the
simultaneous chi-square threshold of the profiles, in the subspace that some test of the space can
identify (directions no test identifies are reported once, as ``not_identifiable_by_any``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from fmuid.data import OutputSpec, Spec
from fmuid.estimation.optimize import jacobian
from fmuid.estimation.predictor import Predictor
from fmuid.estimation.problem import Problem
from fmuid.experiment_design.signals import Trial, trial_experiment
from fmuid.experiment_design.space import Space
from fmuid.model.fmu import FmuModel
from fmuid.profiling.structural import NULL_TOLERANCE, structural_check

INVOLVED = 0.05
"""A parameter takes part in a null direction when its component exceeds this (unit vector)."""


def trial_spec(
    spec: Spec, space: Space, trial: Trial, outputs: Sequence[str] | None = None
) -> Spec:
    """Return the study spec of a trial: its sensors with the space's noise, its test values."""
    names = list(outputs if outputs is not None else trial.outputs)
    return spec.model_copy(
        update={
            "outputs": {o: OutputSpec(sigma=space.outputs[o].sigma) for o in names},
            "fixed": {**spec.fixed, **trial.fixed},
            "inputs": [space.input],
        }
    )


def trial_problem(
    model: FmuModel,
    spec: Spec,
    space: Space,
    trial: Trial,
    values: Mapping[str, np.ndarray] | None = None,
    predictor: Predictor | None = None,
) -> Problem:
    """Return the estimation problem of a trial (data: ``values`` at the sensor times, or zeros)."""
    exp = trial_experiment(trial, space.input, values)
    return Problem(
        model.path, [exp], trial_spec(spec, space, trial), model=model, predictor=predictor
    )


@dataclass(frozen=True)
class Sensitivity:
    """Weighted sensitivities of one trial at one parameter point.

    Attributes
    ----------
    jacobian
        ``d(y/sigma)/dz``, rows grouped by output in ``outputs`` order.
    outputs
        The trial's sensors.
    rows
        Sensor samples per output.

    """

    jacobian: np.ndarray
    outputs: tuple[str, ...]
    rows: int

    def fisher(self, outputs: Sequence[str] | None = None) -> np.ndarray:
        """Fisher information of a subset of the sensors (default all)."""
        keep = [
            self.jacobian[i * self.rows : (i + 1) * self.rows]
            for i, o in enumerate(self.outputs)
            if outputs is None or o in outputs
        ]
        j = np.vstack(keep)
        return j.T @ j


def sensitivity(problem: Problem, values: Mapping[str, float]) -> Sensitivity:
    """Weighted sensitivities of a trial problem at ``values``."""
    jac = jacobian(problem, problem.to_z(values))
    outputs = tuple(problem.outputs)
    return Sensitivity(jac, outputs, jac.shape[0] // len(outputs))


def null_space(sens: Sequence[Sensitivity], problem: Problem, values: Mapping[str, float]) -> dict:
    """Directions that no trial identifies: the structural check of the stacked sensitivities.

    Each trial's rows are scaled to unit norm so that none dominates.
    """
    stacked = np.vstack([s.jacobian / max(np.linalg.norm(s.jacobian), 1e-300) for s in sens])
    return structural_check(
        stacked, problem.names, problem.scales, [values[n] for n in problem.names]
    )


def identifiable_basis(combinations: Sequence[Mapping], names: Sequence[str]) -> np.ndarray:
    """Orthonormal basis (columns) of the complement of the null directions."""
    n = len(names)
    null = []
    for c in combinations:
        v = np.zeros(n)
        for p, d in zip(c["parameters"], c["direction"], strict=True):
            v[names.index(p)] = d
        null.append(v)
    if not null:
        return np.eye(n)
    u, s, _ = np.linalg.svd(np.column_stack(null), full_matrices=True)
    return u[:, len(null) :]


def structural_names(combinations: Sequence[Mapping]) -> set[str]:
    """Parameters that take part in a direction no trial identifies."""
    return {p for c in combinations for p in c["parameters"]}


def criterion(fisher: np.ndarray, basis: np.ndarray, kind: str, threshold: float) -> float:
    """Half-width [z units] of the confidence ellipsoid: geometric-mean axis (D) or longest (E).

    ``inf`` when the information is singular in the identifiable subspace.
    """
    reduced = basis.T @ fisher @ basis
    eig = np.linalg.eigvalsh(reduced)
    if eig.size == 0:
        return 0.0
    if eig[0] <= NULL_TOLERANCE**2 * max(eig[-1], 1e-300):
        return float("inf")
    if kind == "E":
        return float(np.sqrt(threshold / eig[0]))
    return float(np.sqrt(threshold) * np.exp(-0.5 * np.mean(np.log(eig))))


def predicted_intervals(
    fisher: np.ndarray,
    basis: np.ndarray,
    problem: Problem,
    values: Mapping[str, float],
    threshold: float,
    structural: set[str],
) -> dict[str, dict[str, object]]:
    """Predicted simultaneous interval and label of every free parameter.

    A parameter in a null direction is ``structurally_non_identifiable`` (no interval); one whose
    predicted interval leaves its bounds is ``practically_non_identifiable`` with that end null.
    """
    reduced = basis.T @ fisher @ basis
    try:
        cov = basis @ np.linalg.inv(reduced) @ basis.T
    except np.linalg.LinAlgError:
        cov = np.full((problem.n_free,) * 2, np.inf)
    z = problem.to_z(values)
    out: dict[str, dict[str, object]] = {}
    for i, name in enumerate(problem.names):
        if name in structural:
            out[name] = {"ci": [None, None], "status": "structurally_non_identifiable"}
            continue
        hw = float(np.sqrt(threshold * max(cov[i, i], 0.0))) if np.isfinite(cov[i, i]) else np.inf
        lo, hi = z[i] - hw, z[i] + hw
        ends = [
            problem.from_z(_with(z, i, lo))[name] if lo >= problem.z_lower[i] else None,
            problem.from_z(_with(z, i, hi))[name] if hi <= problem.z_upper[i] else None,
        ]
        status = "identifiable" if None not in ends else "practically_non_identifiable"
        out[name] = {"ci": ends, "status": status, "width_z": 2 * hw}
    return out


def _with(z: np.ndarray, i: int, value: float) -> np.ndarray:
    z = z.copy()
    z[i] = value
    return z


def robust_points(
    spec: Spec, space: Space, problem: Problem, rng: np.random.Generator
) -> list[dict[str, float]]:
    """Return the nominal (spec start) and ``space.robust.points`` Latin-hypercube points."""
    nominal = {n: float(p.start) for n, p in spec.parameters.items()}
    k = space.robust.points
    if k == 0:
        return [nominal]
    box = [
        space.robust.box.get(n, (problem.lower[i], problem.upper[i]))
        for i, n in enumerate(problem.names)
    ]
    lo = problem.to_z_array(np.array([b[0] for b in box]))
    hi = problem.to_z_array(np.array([b[1] for b in box]))
    strata = (
        rng.permuted(np.tile(np.arange(k), (len(box), 1)), axis=1).T + rng.random((k, len(box)))
    ) / k
    return [nominal, *(problem.from_z(lo + (hi - lo) * row) for row in strata)]
