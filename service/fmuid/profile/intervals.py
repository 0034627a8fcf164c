"""Confidence-interval ends, limiting parameters and identifiability labels from a profile."""

from __future__ import annotations

import numpy as np

from fmuid.profile.result import (
    IDENTIFIABLE,
    PRACTICALLY_NON_IDENTIFIABLE,
    STRUCTURALLY_NON_IDENTIFIABLE,
    ProfilePoint,
)

#: A profile is flat when it rises by less than this fraction of the simultaneous threshold.
FLAT_FRACTION = 0.1


def ci_end(
    side: list[tuple[float, ProfilePoint]], chi2_hat: float, threshold: float
) -> tuple[float | None, tuple[str, ...]]:
    """Where the profile first crosses ``chi2_hat + threshold`` on one side of the estimate.

    Parameters
    ----------
    side
        ``(z, point)`` pairs ordered from the estimate outwards, the estimate first; failed
        points are skipped.
    chi2_hat
        Chi2 at the optimum.
    threshold
        The chi2 rise that bounds the interval.

    Returns
    -------
    z, limited_by
        The crossing in fitted coordinates (``None`` when not crossed), interpolated linearly in
        the signed root ``sqrt(chi2 - chi2_hat)``, which is linear in ``z`` for a parabolic
        profile; and the other parameters on a bound at the first point past the crossing.

    """
    ok = [(z, p) for z, p in side if p.error is None and np.isfinite(p.chi2)]
    target = np.sqrt(threshold)
    for (z0, p0), (z1, p1) in zip(ok, ok[1:]):
        r0 = np.sqrt(max(p0.chi2 - chi2_hat, 0.0))
        r1 = np.sqrt(max(p1.chi2 - chi2_hat, 0.0))
        if r1 >= target > r0:
            frac = 1.0 if r1 == r0 else (target - r0) / (r1 - r0)
            return z0 + float(np.clip(frac, 0.0, 1.0)) * (z1 - z0), tuple(p1.at_bound)
    return None, ()


def label(
    points: list[ProfilePoint],
    chi2_hat: float,
    threshold: float,
    ci: tuple[float | None, float | None],
) -> str:
    """Return the identifiability label of a profile (contract "status", simultaneous threshold).

    ``structurally_non_identifiable`` when the profile rises by less than
    ``FLAT_FRACTION * threshold`` over the stretch where no other parameter sits on a bound
    (at least three points); ``identifiable`` when both CI ends are finite;
    ``practically_non_identifiable`` otherwise.
    """
    free_stretch = [
        p.chi2 for p in points if not p.at_bound and p.error is None and np.isfinite(p.chi2)
    ]
    if len(free_stretch) >= 3 and max(free_stretch) - chi2_hat < FLAT_FRACTION * threshold:
        return STRUCTURALLY_NON_IDENTIFIABLE
    if ci[0] is not None and ci[1] is not None:
        return IDENTIFIABLE
    return PRACTICALLY_NON_IDENTIFIABLE
