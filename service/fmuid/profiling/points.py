"""Points of a profile branch in fitted coordinates."""

from __future__ import annotations

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
