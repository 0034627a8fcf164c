"""Where a threshold starts to act: levels between a screened value without effect and one with.

A declared parameter's screen grid spreads over its bounds (:func:`.scan._grid`). For a level
that clips or cuts (an overflow, a saturation the FMU declares), most of that grid lies either
where the signals never reach (no effect at all) or far inside their range (clipping much of
the record); the level the data carry is near the onset, between the last grid value without
effect and the first with one. The screen bisects that gap (in the parameter's scale) so the
levels near the onset, where a hard threshold clips only a few samples, are tried too.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from fmuid.discrepancy.knowledge import AddedParameter

NO_EFFECT = 1e-6
"""A value changes the weighted residuals by less than this (chi2 units): it has no effect."""

BISECTIONS = 5
"""Bisections of each gap between a grid value without effect and its neighbour with one
(the onset located to a 32nd of the grid's step; one simulation each)."""


def onset_levels(
    p: AddedParameter,
    tried: Sequence[tuple[float, np.ndarray]],
    residuals: Callable[[dict[str, float]], np.ndarray],
    r0: np.ndarray,
) -> list[tuple[float, np.ndarray]]:
    """Return the bisected values near each onset, with their weighted residuals.

    Parameters
    ----------
    p
        The candidate's one parameter.
    tried
        The screened values and their weighted residuals.
    residuals
        Simulates the model with ``{p.name: value}`` and returns its weighted residuals.
    r0
        The weighted residuals of the model without the candidate.

    Returns
    -------
    list of (value, residuals)
        Only values with an effect (a value without one adds nothing to the screen).

    """
    log_scale = p.spec.resolved_scale == "log"

    def felt(r: np.ndarray) -> bool:
        d = r0 - r
        return bool(d @ d > NO_EFFECT)

    def middle(a: float, b: float) -> float:
        return float(np.sqrt(a * b)) if log_scale and a > 0 and b > 0 else 0.5 * (a + b)

    found: list[tuple[float, np.ndarray]] = []
    ordered = sorted(tried, key=lambda item: item[0])
    for (a, ra), (b, rb) in zip(ordered, ordered[1:]):
        if felt(ra) == felt(rb):
            continue
        inside, outside = (a, b) if felt(ra) else (b, a)
        for _ in range(BISECTIONS):
            value = middle(inside, outside)
            r = residuals({p.name: value})
            if felt(r):
                inside = value
                found.append((value, r))
            else:
                outside = value
    return found
