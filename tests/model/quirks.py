"""Test FMUs that reproduce exporters' quirks, built from ``tests/model/fmus_src``.

Each model folder there is either a ``variables.json`` and a ``model.c`` as in ``model_src`` (a
model may replace fmuid's shared FMI layer by a file of ``fmus_src`` that wraps it; the shared
layer is copied beside it as ``fmi2_cs_shared.c``), or a ``modelDescription.xml``, ``config.h``,
``model.c`` and ``all.c`` written for the Reference-FMUs' framework (model exchange), compiled
with the framework files from a Reference-FMU's ``sources/`` folder.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import fmpy
from tests.model.foreign import reference_fmu

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
    for item in ("model.h", "linear_step.h", "units.json"):
        shutil.copy(model_src_dir() / item, src / item)
    shutil.copy(model_src_dir() / "fmi2_cs.c", src / "fmi2_cs_shared.c")
    shutil.copy(FMUS_SRC / layer, src / "fmi2_cs.c")
    return build_fmu(src, FMUS_SRC / name, out_dir)


def build_framework_fmu(name: str, out_dir: Path) -> Path:
    """Compile ``fmus_src/<name>`` on the Reference-FMUs' framework into ``<out_dir>/<name>.fmu``.

    The framework comes from the sources of the FMI 2.0 VanDerPol Reference-FMU (the test is
    skipped when it is absent).
    """
    build = out_dir / "build"
    build.mkdir(exist_ok=True)
    own = {p.name for p in (FMUS_SRC / name).iterdir()}
    with zipfile.ZipFile(reference_fmu("fmi2", "VanDerPol")) as archive:
        for item in archive.namelist():
            file = Path(item).name
            if item.startswith("sources/") and file and file not in own:
                (build / file).write_bytes(archive.read(item))
    for file in own:
        shutil.copy(FMUS_SRC / name / file, build / file)
    library = build / f"{name}.so"
    headers = Path(os.path.dirname(fmpy.__file__)) / "c-code"
    subprocess.run(
        [
            "gcc",
            "-shared",
            "-fPIC",
            "-O2",
            f"-I{headers}",
            f"-I{build}",
            "-o",
            str(library),
            str(build / "all.c"),
            "-lm",
        ],
        check=True,
        capture_output=True,
    )
    target = out_dir / f"{name}.fmu"
    with zipfile.ZipFile(target, "w") as archive:
        archive.write(build / "modelDescription.xml", "modelDescription.xml")
        archive.write(library, f"binaries/linux64/{name}.so")
    return target
