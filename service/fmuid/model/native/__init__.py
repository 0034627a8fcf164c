"""Compiled master loops, called through ctypes with the FMU's own FMI function pointers.

The C sources live beside this file and are compiled by gcc on first use (or by
``fmuid build-fmus``) into the folder of the built-in FMUs (:func:`fmuid.model.builtin.fmu_dir`),
named by a hash of the source. Without gcc, or if compiling fails, the Python loops run instead
(one log line says so); ``FMUID_NATIVE=0`` chooses the Python loops. The Python loops stay the
reference: the native ones are tested against them to rounding.
"""

from fmuid.model.native.build import native_library
from fmuid.model.native.loop import run_native_cosimulation

__all__ = ["native_library", "run_native_cosimulation"]
