"""Points of a profile branch in fitted coordinates."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WalkPoint:
    """A point of a branch in fitted coordinates (``z`` holds every free parameter)."""

    z: np.ndarray
    chi2: float
    error: str | None = None

    @property
    def ok(self) -> bool:
        """Whether the re-fit there succeeded with a finite chi2."""
        return self.error is None and bool(np.isfinite(self.chi2))
