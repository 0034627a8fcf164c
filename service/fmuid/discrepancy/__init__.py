"""Model discrepancy: locate a mismatch, name the left-out physics, model it, show the gain.

The package's names are imported on first use, so that :mod:`.effects` and :mod:`.augment`
(which the experiment design uses) load without the diagnosis engine.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["DiagnoseOptions", "Diagnosis", "diagnose", "diagnose_problem"]

_HOMES = {
    "DiagnoseOptions": "fmuid.discrepancy.engine",
    "diagnose_problem": "fmuid.discrepancy.engine",
    "Diagnosis": "fmuid.discrepancy.result",
    "diagnose": "fmuid.discrepancy.study",
}


def __getattr__(name: str) -> Any:
    """Import a public name from its module on first use."""
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'fmuid.discrepancy' has no attribute {name!r}")
    return getattr(importlib.import_module(home), name)
