"""Estimation: the least-squares problem over an FMU, its global start and trust-region fit.

The names below are imported on first use, so that a light module of the package (e.g.
:mod:`fmuid.estimation.predictor`, which ``fmuid simulate`` needs) does not load scipy's
optimisers and pymoo.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_LAZY = {
    "FitOptions": "fmuid.estimation.optimize",
    "fit_problem": "fmuid.estimation.optimize",
    "Problem": "fmuid.estimation.problem",
    "FitResult": "fmuid.estimation.result",
    "ParameterSpace": "fmuid.estimation.space",
}

__all__ = ["FitOptions", "FitResult", "ParameterSpace", "Problem", "fit_problem"]

if TYPE_CHECKING:
    from fmuid.estimation.optimize import FitOptions, fit_problem
    from fmuid.estimation.problem import Problem
    from fmuid.estimation.result import FitResult
    from fmuid.estimation.space import ParameterSpace


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'fmuid.estimation' has no attribute {name!r}")
    return getattr(importlib.import_module(_LAZY[name]), name)
