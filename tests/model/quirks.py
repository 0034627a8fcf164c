"""Test FMUs that reproduce exporters' quirks, built from ``tests/model/fmus_src``.

Each model folder there is a ``variables.json`` and a ``model.c`` as in ``model_src``; a model
may replace fmuid's shared FMI layer by a file of ``fmus_src`` that wraps it (the shared layer
is copied beside it as ``fmi2_cs_shared.c``).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from fmuid.model.build import build_fmu
from fmuid.model.builtin import model_src_dir

FMUS_SRC = Path(__file__).parent / "fmus_src"

LAYERS = {"setup_resets": "setup_experiment_resets.c"}
"""Model -> the FMI layer that replaces the shared one by default."""


def build_quirk_fmu(name: str, out_dir: Path, layer: str | None = None) -> Path:
    """Compile ``fmus_src/<name>`` into ``<out_dir>/<name>.fmu``.

    ``layer`` (a file of ``fmus_src``) replaces the shared FMI layer; default: ``LAYERS``'s.
    """
    layer = layer or LAYERS.get(name)
    if layer is None:
        return build_fmu(model_src_dir(), FMUS_SRC / name, out_dir)
    src = out_dir / "src"
    src.mkdir(exist_ok=True)
    for item in ("model.h", "units.json"):
        shutil.copy(model_src_dir() / item, src / item)
    shutil.copy(model_src_dir() / "fmi2_cs.c", src / "fmi2_cs_shared.c")
    shutil.copy(FMUS_SRC / layer, src / "fmi2_cs.c")
    return build_fmu(src, FMUS_SRC / name, out_dir)
