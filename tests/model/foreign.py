"""Where the Modelica Reference-FMUs live (../shared/reference-fmus) and how tests find them."""

from __future__ import annotations

import os
import re
import zipfile
from pathlib import Path

import pytest

REFERENCE_DIR = Path(
    os.environ.get(
        "FMUID_REFERENCE_FMUS", Path(__file__).resolve().parents[3] / "shared" / "reference-fmus"
    )
)


def reference_fmu(version: str, name: str) -> Path:
    """Path of ``fmi2/<name>.fmu`` or ``fmi3/<name>.fmu``; skip the test when it is absent."""
    path = REFERENCE_DIR / version / f"{name}.fmu"
    if not path.is_file():
        pytest.skip(f"Reference-FMU {path} is absent (set FMUID_REFERENCE_FMUS to their folder)")
    return path


def model_exchange_only(source: Path, target: Path) -> Path:
    """Copy an FMU without its co-simulation interface (so fmuid must use model exchange)."""
    with zipfile.ZipFile(source) as src, zipfile.ZipFile(target, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb"<CoSimulation.*?(/>|</CoSimulation>)", b"", data, flags=re.S)
            dst.writestr(item, data)
    return target
