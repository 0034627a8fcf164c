"""fmuid: black-box identifiability of FMU parameters (fits, profile likelihoods, diagnosis).

The stages are plain functions: ``fmuid.simulate``, ``fmuid.fit``, ``fmuid.profile``,
``fmuid.diagnose`` and ``fmuid.design``; ``fmuid.info`` describes a model, ``fmuid.load_result``
reads a saved result back. Their machinery lives in packages with noun names, so no function
shadows a package: :mod:`fmuid.estimation` (fits), :mod:`fmuid.profiling` (profile likelihoods),
:mod:`fmuid.discrepancy` (diagnosis) and :mod:`fmuid.experiment_design` (experiment design).

The stages are imported on first use, so that ``import fmuid`` (and ``fmuid --help``) stays fast.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

_LAZY = {
    "simulate": "fmuid.stages",
    "fit": "fmuid.stages",
    "profile": "fmuid.stages",
    "diagnose": "fmuid.discrepancy",
    "design": "fmuid.experiment_design",
    "info": "fmuid.model.info",
    "load_result": "fmuid.results",
}

__all__ = [
    "__version__",
    "design",
    "diagnose",
    "fit",
    "info",
    "load_result",
    "profile",
    "simulate",
]

if TYPE_CHECKING:
    from fmuid.discrepancy import diagnose
    from fmuid.experiment_design import design
    from fmuid.model.info import info
    from fmuid.results import load_result
    from fmuid.stages import fit, profile, simulate


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'fmuid' has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value
    return value
