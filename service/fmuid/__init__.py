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
import sys
from collections.abc import Callable
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


def lazy_names(package: str, table: dict[str, str]) -> Callable[[str], Any]:
    """Return a module ``__getattr__`` that imports each name of ``table`` on its first use.

    ``table`` maps a name of the module ``package`` to the module that defines it.
    """

    def __getattr__(name: str) -> Any:
        if name not in table:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(table[name]), name)
        setattr(sys.modules[package], name, value)
        return value

    return __getattr__


__getattr__ = lazy_names(__name__, _LAZY)
