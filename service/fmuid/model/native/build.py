"""Compile ``loop.c`` once into a shared library and load it (None when that is impossible)."""

from __future__ import annotations

import ctypes
import functools
import hashlib
import logging
import os
import subprocess
from pathlib import Path

from fmuid.errors import BuildError
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
    BuildError
        If gcc is missing or fails, or the folder is not writable (naming which).

    """
    partial = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    command = ["gcc", *FLAGS, "-o", str(partial), str(SOURCE), "-lm"]
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BuildError(f"cannot write the compiled loop to {target}: {exc}") from exc
    try:
        done = subprocess.run(command, capture_output=True, text=True, check=False)
    except FileNotFoundError as exc:
        raise BuildError(f"cannot compile {SOURCE}: gcc was not found on PATH") from exc
    try:
        if done.returncode != 0:
            raise BuildError(f"cannot compile {SOURCE}: gcc failed:\n{done.stderr.strip()}")
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
    except (BuildError, OSError) as exc:
        logger.warning("native master loop unavailable (%s); using the Python loop", exc)
        return None
    for function in (lib.fmuid_cosimulation, lib.fmuid_feedback):
        function.restype = ctypes.c_int
    lib.fmuid_cosimulation.argtypes = [ctypes.c_void_p]
    lib.fmuid_feedback.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
    return lib
