"""Points of a profile branch in fitted coordinates."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WalkPoint:
    """A point of a branch in fitted coordinates (``z`` holds every free parameter).

    ``carried``: its chi2 comes from Gauss-Newton steps on the Jacobian carried along the walk
    (:mod:`fmuid.profiling.quasi`), which goes stale in the directions the walk did not move:
    such a re-fit may settle above the profile (by up to 0.4 on the tractor's low-SNR studies),
    so a rise it reports over a threshold is confirmed by a fresh re-fit before it ends a walk
    or brackets a CI end.
    """

    z: np.ndarray
    chi2: float
    error: str | None = None
    carried: bool = False

    @property
    def ok(self) -> bool:
        """Whether the re-fit there succeeded with a finite chi2."""
        return self.error is None and bool(np.isfinite(self.chi2))


def lower_envelope(
    new: Sequence[WalkPoint], old: Sequence[WalkPoint], index: int, origin: float, tol: float
) -> list[WalkPoint]:
    """Return the points of two walks of one branch on their lower envelope, from ``origin`` out.

    A re-walk from a lower valley (``new``) follows that valley outwards; where the walk before
    it (``old``) was lower, further out, its points are the profile there (every point is a
    re-fit at its own value of parameter ``index``, an upper bound of the profile). A point of
    either walk is left out when the other walk's straight line between its neighbours (at
    equal values, the other's point) lies more than ``tol`` below it; points outside the other
    walk's reach stay. Failed points of ``new`` stay.
    """

    def dist(p: WalkPoint) -> float:
        return abs(float(p.z[index]) - origin)

    def below(p: WalkPoint, path: list[WalkPoint]) -> bool:
        """Whether ``path``'s straight line at ``p``'s distance lies ``tol`` below ``p``."""
        d = dist(p)
        inner = [q for q in path if dist(q) <= d]
        outer = [q for q in path if dist(q) >= d]
        if not inner or not outer:
            return False
        a, b = max(inner, key=dist), min(outer, key=dist)
        if dist(b) == dist(a):
            return min(a.chi2, b.chi2) < p.chi2 - tol
        level = a.chi2 + (b.chi2 - a.chi2) * (d - dist(a)) / (dist(b) - dist(a))
        return level < p.chi2 - tol

    fresh = [p for p in new if p.ok]
    former = [p for p in old if p.ok and all(p is not q for q in new)]
    kept = [p for p in former if not below(p, fresh)]
    kept += [p for p in new if not p.ok or not below(p, former)]
    return sorted(kept, key=dist)
