"""Where the built-in FMUs (compiled from ``model_src/``) live, building them on first use.

The C sources ship inside the package (``fmuid/model_src``, a link to the repository's
``model_src/`` in a source tree, package data in a wheel). The FMUs are built next to the
sources in a source tree (``<repo>/fmus``) and into a user cache folder in an installed package.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

from fmuid.errors import FmuError
from fmuid.model.build import build_fmus

logger = logging.getLogger(__name__)

BUILTIN_MODELS = ("tractor_implement", "msd", "msd_parallel", "emps")

_PACKAGE = Path(__file__).resolve().parents[1]


def _repository() -> Path | None:
    """Return the source tree holding this package, or ``None`` for an installed package."""
    root = _PACKAGE.parents[1]
    return root if (root / "pyproject.toml").is_file() and (root / "model_src").is_dir() else None


def cache_dir() -> Path:
    """User cache folder of fmuid: ``$XDG_CACHE_HOME/fmuid``, else ``~/.cache/fmuid``."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "fmuid"


def fmu_dir() -> Path:
    """Folder of the built-in FMUs.

    ``$FMUID_FMU_DIR`` when set; else ``<repo>/fmus`` in a source tree; else
    ``<user cache>/fmus/<fmuid version>`` (see :func:`cache_dir`).
    """
    configured = os.environ.get("FMUID_FMU_DIR")
    if configured:
        return Path(configured)
    repo = _repository()
    if repo is not None:
        return repo / "fmus"
    from fmuid import __version__

    return cache_dir() / "fmus" / __version__


def model_src_dir() -> Path:
    """Folder of the C sources: ``$FMUID_MODEL_SRC``, else the package's ``model_src``."""
    configured = os.environ.get("FMUID_MODEL_SRC")
    return Path(configured) if configured else _PACKAGE / "model_src"


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
