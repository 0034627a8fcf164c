"""Numerical structural pre-check: null directions of the weighted sensitivity matrix."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from fmuid.estimation.space import value_step

#: A singular value below this fraction of the largest counts as zero.
NULL_TOLERANCE = 1e-6
#: Two components agree when their magnitudes differ by less than this fraction.
MATCH_TOLERANCE = 0.05


def structural_check(
    jacobian: np.ndarray,
    names: Sequence[str],
    scales: Sequence[str],
    estimates: Sequence[float],
) -> dict[str, Any]:
    """Singular values of the weighted sensitivity matrix and its near-null directions.

    A parameter whose column is zero (or below ``NULL_TOLERANCE`` of the largest column) moves
    no output: it is a null direction on its own, even when every column is zero. Among the
    others, a singular value near zero means that moving the parameters along the corresponding
    right singular vector leaves every output unchanged: those parameters are identifiable only
    in combination. For two parameters the combination is named when it is a sum, difference,
    product or ratio (e.g. springs in parallel: only ``k1 + k2``).

    Parameters
    ----------
    jacobian
        Weighted sensitivities ``d(y/sigma)/dz`` at the estimate, shape ``(n_data, n_free)``,
        in fitted coordinates (``z = log10(value)`` for log-scaled parameters).
    names, scales, estimates
        Free parameters, their scales and estimated values.

    Returns
    -------
    dict
        ``singular_values`` (descending) and ``non_identifiable_combinations`` (each with
        ``parameters``, unit ``direction`` in fitted coordinates and ``meaning``).

    """
    jacobian = np.asarray(jacobian, dtype=float).reshape(-1, len(names))
    norms = np.linalg.norm(jacobian, axis=0)
    largest = float(np.max(norms, initial=0.0))
    dead = [i for i in range(len(names)) if not norms[i] > NULL_TOLERANCE * largest]
    combos = [_combination(np.eye(len(names))[i], names, scales, estimates) for i in dead]
    live = [i for i in range(len(names)) if i not in dead]
    _, s, _ = np.linalg.svd(jacobian, full_matrices=False)
    if live:
        _, s_live, vt_live = np.linalg.svd(jacobian[:, live], full_matrices=False)
        for k in np.nonzero(s_live < NULL_TOLERANCE * s_live[0])[0]:
            row = np.zeros(len(names))
            row[live] = vt_live[k]
            combos.append(_combination(row, names, scales, estimates))
    return {
        "singular_values": [float(x) for x in s],
        "non_identifiable_combinations": combos,
    }


def _combination(
    direction: np.ndarray, names: Sequence[str], scales: Sequence[str], estimates: Sequence[float]
) -> dict[str, Any]:
    """One null direction (a unit vector over all parameters) in the form of the result."""
    v = direction / np.max(np.abs(direction))
    v = v if v[np.argmax(np.abs(v))] > 0 else -v
    involved = [i for i in range(len(names)) if abs(v[i]) > 0.05]
    return {
        "parameters": [names[i] for i in involved],
        "direction": [round(float(direction[i]), 6) for i in involved],
        "meaning": _meaning(v, involved, names, scales, estimates),
    }


def _meaning(
    v: np.ndarray,
    involved: list[int],
    names: Sequence[str],
    scales: Sequence[str],
    estimates: Sequence[float],
) -> str:
    listed = ", ".join(names[i] for i in involved)
    if len(involved) == 1:
        return f"{listed} has no effect on the outputs here"
    if len(involved) == 2:
        i, j = involved
        a, b = names[i], names[j]
        lin = [value_step(v[n], estimates[n], scales[n]) for n in (i, j)]
        if _same_magnitude(lin[0], lin[1]):
            return (
                f"only {a} + {b} is identifiable"
                if lin[0] * lin[1] < 0
                else (f"only {a} - {b} is identifiable")
            )
        if scales[i] == "log" and scales[j] == "log" and _same_magnitude(v[i], v[j]):
            return (
                f"only {a} * {b} is identifiable"
                if v[i] * v[j] < 0
                else (f"only {a} / {b} is identifiable")
            )
    weights = ", ".join(f"{v[i]:+.3g} {names[i]}" for i in involved)
    return (
        f"{listed} compensate each other: moving along ({weights}) in fitted coordinates leaves "
        "the outputs unchanged, so only the orthogonal combination is identifiable"
    )


def _same_magnitude(x: float, y: float) -> bool:
    return abs(abs(x) - abs(y)) <= MATCH_TOLERANCE * max(abs(x), abs(y))
