"""Compile ``loop.c`` once into a shared library and load it (None when that is impossible)."""

from __future__ import annotations

import ctypes
import functools
import hashlib
import logging
import os
import subprocess
from pathlib import Path

from fmuid.model.builtin import fmu_dir

logger = logging.getLogger(__name__)

SOURCE = Path(__file__).with_name("loop.c")
FLAGS = ("-shared", "-fPIC", "-O2", "-ffp-contract=off", "-Wall", "-Wextra")
"""gcc flags: no fused multiply-adds, so the loop's arithmetic equals the Python loop's."""


def library_path(folder: Path | None = None) -> Path:
    """Where the compiled loop lives in ``folder`` (default :func:`fmu_dir`).

    Its name holds a hash of the source and the flags, so a changed source is compiled again.
    """
    digest = hashlib.sha256(SOURCE.read_bytes() + " ".join(FLAGS).encode()).hexdigest()[:16]
    return (folder or fmu_dir()) / f"fmuid-loop-{digest}.so"


def compile_library(target: Path) -> None:
    """Compile ``loop.c`` into ``target`` (written atomically).

    Raises
    ------
    OSError, subprocess.CalledProcessError
        If gcc is missing, the folder is not writable or gcc fails.

    """
    target.parent.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    command = ["gcc", *FLAGS, "-o", str(partial), str(SOURCE), "-lm"]
    try:
        subprocess.run(command, capture_output=True, text=True, check=True)
        os.replace(partial, target)
    finally:
        partial.unlink(missing_ok=True)


@functools.cache
def native_library() -> ctypes.CDLL | None:
    """Return the compiled loop, compiling it on first use; None when it cannot be had.

    None also when ``FMUID_NATIVE`` is ``0``. A failure is logged once per process.
    """
    if os.environ.get("FMUID_NATIVE", "1") == "0":
        return None
    path = library_path()
    try:
        if not path.is_file():
            logger.info("compiling the native master loop into %s", path)
            compile_library(path)
        lib = ctypes.CDLL(str(path))
    except (OSError, subprocess.CalledProcessError) as exc:
        detail = getattr(exc, "stderr", None) or exc
        logger.warning("native master loop unavailable (%s); using the Python loop", detail)
        return None
    lib.fmuid_cosimulation.restype = ctypes.c_int
    lib.fmuid_cosimulation.argtypes = [ctypes.c_void_p]
    return lib
