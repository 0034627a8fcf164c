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
#: How the reason of a profile whose ends the FMU's solver noise could move begins.
NOISE_PREFIX = "the FMU's solver noise limits the interval"


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


def profile_noise(z: Sequence[float], chi2: Sequence[float], chi2_hat: float) -> float:
    """Return the largest jump of a walked profile (chi2 units).

    Each interior point is compared with the straight line through its neighbours in the
    signed root ``±sqrt(chi2 - chi2_hat)`` (straight for a parabolic profile, and close to
    straight for any smooth one at the walk's spacing), squared back to chi2.

    Parameters
    ----------
    z
        The profiled parameter's fitted coordinates of the good points, estimate included.
    chi2
        Their chi2.
    chi2_hat
        Chi2 at the optimum.

    """
    order = np.argsort(z)
    x = np.asarray(z, dtype=float)[order]
    c = np.asarray(chi2, dtype=float)[order]
    if x.size < 3:
        return 0.0
    mid = x[int(np.argmin(c))]
    r = np.sign(x - mid) * np.sqrt(np.maximum(c - chi2_hat, 0.0))
    w = (x[1:-1] - x[:-2]) / np.where(x[2:] > x[:-2], x[2:] - x[:-2], 1.0)
    line = r[:-2] + w * (r[2:] - r[:-2])
    return float(np.max(np.abs(c[1:-1] - chi2_hat - line**2)))


def noise_limited(
    status: str,
    reason: str,
    noise: float,
    threshold: float,
    ci: tuple[float | None, float | None],
    estimate: float,
) -> tuple[str, str]:
    """Return the label and reason of a profile whose chi2 jumps by up to ``noise``.

    A jump of ``noise`` at an end moves it by about ``noise / (2 * threshold)`` of its
    half-width (the slope of a parabolic profile there), so no end is trusted to be
    ``identifiable``: such a profile becomes ``practically_non_identifiable`` with a sentence
    saying by how much; an open or flat profile keeps its label and gets the sentence added.

    Parameters
    ----------
    status, reason
        The label and reason from :func:`label`.
    noise
        The health check's noise floor in chi2 units (largest jump).
    threshold
        The simultaneous threshold.
    ci
        The simultaneous interval (``None`` for an open end).
    estimate
        The parameter's estimate.

    """
    shift = noise / (2.0 * threshold)
    ends = [f"{e:.6g} \u00b1 {abs(e - estimate) * shift:.2g}" for e in ci if e is not None]
    sentence = (
        f"{NOISE_PREFIX}: chi2 jumps by up to {noise:.3g} (the FMU's noise floor in chi2 "
        f"units) as the parameters move, which could move each end by about {shift:.0%} of its "
        "half-width" + (f" ({', '.join(ends)})" if ends else "")
    )
    if status == IDENTIFIABLE:
        return PRACTICALLY_NON_IDENTIFIABLE, sentence
    return status, f"{reason}; {sentence}"
