"""Identifiability labels of a profile, with the reason in words."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fmuid.profiling.result import (
    IDENTIFIABLE,
    PRACTICALLY_NON_IDENTIFIABLE,
    STRUCTURALLY_NON_IDENTIFIABLE,
    ProfilePoint,
)

#: A profile is flat when it rises by less than this fraction of the simultaneous threshold.
FLAT_FRACTION = 0.1


def is_flat(points: Sequence[ProfilePoint], chi2_hat: float, threshold: float) -> bool:
    """Tell whether the profile is flat.

    Flat: it rises by less than ``FLAT_FRACTION * threshold`` over the stretch where no other
    parameter sits on a bound (at least three such points).
    """
    free_stretch = [
        p.chi2 for p in points if not p.at_bound and p.error is None and np.isfinite(p.chi2)
    ]
    return len(free_stretch) >= 3 and max(free_stretch) - chi2_hat < FLAT_FRACTION * threshold


def label(
    name: str,
    flat: bool,
    ci: tuple[float | None, float | None],
    why_open: tuple[str, str],
    null_partners: Sequence[str] | None,
    meaning: str = "",
) -> tuple[str, str]:
    """Return the identifiability label of a profile and the reason (simultaneous threshold).

    Parameters
    ----------
    name
        The parameter.
    flat
        Whether the profile is flat (:func:`is_flat`).
    ci
        The simultaneous interval (``None`` for an open end).
    why_open
        Why each end (lower, upper) is open: ``"bound"``, ``"walk stopped"`` or ``""``.
    null_partners
        The parameters of a null direction of the noise-free sensitivities that involves
        ``name`` (at the estimate or along the profile), or ``None`` when none does.
    meaning
        What that null direction means, e.g. ``"only k1 + k2 is identifiable"``.

    Returns
    -------
    status, reason
        ``structurally_non_identifiable`` only for a flat profile whose parameter is in a null
        direction; ``identifiable`` when both ends are finite; otherwise
        ``practically_non_identifiable``.

    """
    if flat and null_partners is not None and not null_partners:
        return STRUCTURALLY_NON_IDENTIFIABLE, (
            f"the profile is flat and {meaning or name + ' has no effect on the outputs'}"
        )
    if flat and null_partners is not None:
        return STRUCTURALLY_NON_IDENTIFIABLE, (
            f"the profile is flat and the noise-free sensitivities have a null direction "
            f"involving {', '.join(null_partners)}: {meaning or 'they compensate each other'}"
        )
    if ci[0] is not None and ci[1] is not None:
        return IDENTIFIABLE, "the profile crosses the simultaneous threshold on both sides"
    rank = (
        "the noise-free sensitivities have full rank, so the data, not the model, leave it open"
        if null_partners is None
        else f"{name} is in a null direction of the sensitivities with {', '.join(null_partners)}"
        if null_partners
        else f"{name} moves no output at the estimate"
    )
    if flat:
        return PRACTICALLY_NON_IDENTIFIABLE, f"the profile is flat within the bounds; {rank}"
    sides = []
    for end, side, why in zip(ci, ("below", "above"), why_open, strict=True):
        if end is None:
            how = "up to the bound" if why == "bound" else "where the walk stopped"
            sides.append(f"{side} the estimate ({how})")
    return PRACTICALLY_NON_IDENTIFIABLE, (
        f"the profile stays under the simultaneous threshold {' and '.join(sides)}; {rank}"
    )


def open_reason(side: Sequence[ProfilePoint], value_bound: float) -> str:
    """``"bound"`` when the outermost good point of an open side is at the parameter's bound."""
    ok = [p for p in side if p.error is None and np.isfinite(p.chi2)]
    if ok and np.isclose(ok[-1].value, value_bound, rtol=1e-9, atol=0.0):
        return "bound"
    return "walk stopped"
