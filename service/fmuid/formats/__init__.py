"""Standard files: SSP 2.0 parameter values (SSV) and PEtab-v2-style problems with an FMU model.

See docs/formats.md for the mapping of fmuid's study and results onto these files. The names
below load their module on first use, so that the command line starts fast.
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "ParameterSet": "ssv",
    "SsvEstimate": "ssv",
    "fmu_unit_definitions": "ssv",
    "read_ssv": "ssv",
    "with_start_values": "ssv",
    "write_ssv": "ssv",
    "PetabProblem": "petab",
    "write_petab": "petab",
    "read_petab": "petab_read",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    """Load ``name`` from its module."""
    if name not in _WHERE:
        raise AttributeError(f"module 'fmuid.formats' has no attribute {name!r}")
    return getattr(importlib.import_module(f"fmuid.formats.{_WHERE[name]}"), name)
