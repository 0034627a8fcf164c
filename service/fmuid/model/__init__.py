"""FMUs: loading, building the built-in models and fast repeated simulation."""

from fmuid.model.build import build_fmus
from fmuid.model.builtin import BUILTIN_MODELS, builtin_fmu, fmu_dir, model_src_dir
from fmuid.model.fmu import FmuModel, Variable
from fmuid.model.registry import get_simulator
from fmuid.model.simulator import Simulator

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
