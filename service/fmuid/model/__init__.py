"""FMUs: loading, building the built-in models and fast repeated simulation.

The names below are imported on first use, so that a process importing one light module of
this package (e.g. :mod:`fmuid.model.world` in the CLI's entry point) does not load fmpy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fmuid import lazy_names

_LAZY = {
    "BUILTIN_MODELS": "fmuid.model.builtin",
    "FmuModel": "fmuid.model.fmu",
    "Simulator": "fmuid.model.simulator",
    "Variable": "fmuid.model.fmu",
    "build_fmus": "fmuid.model.build",
    "builtin_fmu": "fmuid.model.builtin",
    "fmu_dir": "fmuid.model.builtin",
    "get_simulator": "fmuid.model.registry",
    "model_src_dir": "fmuid.model.builtin",
}

__all__ = [
    "BUILTIN_MODELS",
    "FmuModel",
    "Simulator",
    "Variable",
    "build_fmus",
    "builtin_fmu",
    "fmu_dir",
    "get_simulator",
    "model_src_dir",
]

if TYPE_CHECKING:
    from fmuid.model.build import build_fmus
    from fmuid.model.builtin import BUILTIN_MODELS, builtin_fmu, fmu_dir, model_src_dir
    from fmuid.model.fmu import FmuModel, Variable
    from fmuid.model.registry import get_simulator
    from fmuid.model.simulator import Simulator


__getattr__ = lazy_names(__name__, _LAZY)
