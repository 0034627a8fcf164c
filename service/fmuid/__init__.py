"""fmuid: black-box identifiability of FMU parameters (fits, profile likelihoods, diagnosis).

The stages are plain functions: ``fmuid.fit``, ``fmuid.profile`` and ``fmuid.diagnose``;
``fmuid.info`` describes a model, ``fmuid.load_result`` reads a saved result back. The
subpackages ``fit``, ``profile`` and ``diagnose`` share the stages' names and hold their
machinery; import from them with ``from fmuid.fit.problem import Problem`` style imports.

The stages are imported on first use, so that ``import fmuid`` (and ``fmuid --help``) stays fast.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

_LAZY = {
    "fit": "fmuid.stages",
    "profile": "fmuid.stages",
    "diagnose": "fmuid.diagnose",
    "info": "fmuid.model.info",
    "load_result": "fmuid.results",
}

__all__ = ["__version__", "diagnose", "fit", "info", "load_result", "profile"]

if TYPE_CHECKING:
    from fmuid.diagnose import diagnose
    from fmuid.model.info import info
    from fmuid.results import load_result
    from fmuid.stages import fit, profile


class _Package(types.ModuleType):
    """The ``fmuid`` module: its stage functions are never replaced by the same-named subpackages.

    Importing a subpackage such as ``fmuid.fit`` sets the attribute ``fmuid.fit`` to it; the
    stage function of that name stays, and the subpackage stays reachable by import.
    """

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _LAZY and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'fmuid' has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value
    return value


sys.modules[__name__].__class__ = _Package
