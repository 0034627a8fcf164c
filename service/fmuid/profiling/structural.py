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

    A singular value near zero means that moving the parameters along the corresponding
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
    _, s, vt = np.linalg.svd(jacobian, full_matrices=False)
    combos = []
    if s.size and s[0] > 0:
        for k in np.nonzero(s < NULL_TOLERANCE * s[0])[0]:
            v = vt[k] / np.max(np.abs(vt[k]))
            v = v if v[np.argmax(np.abs(v))] > 0 else -v
            involved = [i for i in range(len(names)) if abs(v[i]) > 0.05]
            combos.append(
                {
                    "parameters": [names[i] for i in involved],
                    "direction": [round(float(vt[k][i]), 6) for i in involved],
                    "meaning": _meaning(v, involved, names, scales, estimates),
                }
            )
    return {
        "singular_values": [float(x) for x in s],
        "non_identifiable_combinations": combos,
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
