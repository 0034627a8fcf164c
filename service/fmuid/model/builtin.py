"""Where the built-in FMUs (compiled from ``model_src/``) live, building them on first use."""

from __future__ import annotations

import logging
import os
from pathlib import Path

from fmuid.errors import FmuError
from fmuid.model.build import build_fmus

logger = logging.getLogger(__name__)

BUILTIN_MODELS = ("tractor_implement", "msd", "msd_parallel")


def fmu_dir() -> Path:
    """Folder of the built-in FMUs: ``$FMUID_FMU_DIR``, else ``<repo>/fmus``."""
    configured = os.environ.get("FMUID_FMU_DIR")
    return Path(configured) if configured else Path(__file__).resolve().parents[3] / "fmus"


def model_src_dir() -> Path:
    """Folder of the C sources: ``$FMUID_MODEL_SRC``, else ``<repo>/model_src``."""
    configured = os.environ.get("FMUID_MODEL_SRC")
    return Path(configured) if configured else Path(__file__).resolve().parents[3] / "model_src"


def builtin_fmu(name: str) -> Path:
    """Path of the built-in FMU ``name``, building all built-in FMUs if it is missing or stale.

    An FMU is stale when a file of ``model_src/`` is newer than it (checked only where the
    sources exist, e.g. not in the container's runtime image).

    Parameters
    ----------
    name
        One of :data:`BUILTIN_MODELS`.

    Raises
    ------
    FmuError
        If ``name`` is not a built-in model or the build fails.

    """
    if name not in BUILTIN_MODELS:
        raise FmuError(
            f"unknown built-in model {name!r}; the built-in models are {', '.join(BUILTIN_MODELS)}"
        )
    path = fmu_dir() / f"{name}.fmu"
    if not path.is_file() or _sources_newer_than(path):
        logger.info("building the built-in FMUs into %s", path.parent)
        build_fmus(model_src_dir(), path.parent)
    return path


def _sources_newer_than(path: Path) -> bool:
    src = model_src_dir()
    if not src.is_dir():
        return False
    built = path.stat().st_mtime
    return any(f.stat().st_mtime > built for f in src.rglob("*") if f.is_file())


def resolve_fmu(fmu: str | Path) -> Path:
    """Path of an FMU given as a file or as the name of a built-in model.

    Raises
    ------
    FmuError
        If ``fmu`` is neither an existing file nor a built-in model name.

    """
    path = Path(fmu)
    if not path.exists() and str(fmu) in BUILTIN_MODELS:
        return builtin_fmu(str(fmu))
    if not path.is_file():
        raise FmuError(
            f"FMU file not found: {fmu} (nor is it a built-in model: {', '.join(BUILTIN_MODELS)})"
        )
    return path

