"""Load an FMU's linux64 binary in a throw-away process and check its FMI 2.0 functions.

Run as a script (``python -I probe_fmu.py FMU MEMORY_MB``) by :mod:`fmuid.jobs.fmucheck`; it
imports only the standard library so that it starts fast, and it limits its own memory and file
sizes before touching the upload: loading a shared library runs its constructors, which is
native code from the uploader. Exit status 0 when the binary loads and exports every function
below; otherwise 1 with one line on stderr saying why.
"""

from __future__ import annotations

import ctypes
import re
import resource
import shutil
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

REQUIRED = (
    "fmi2GetVersion",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Reset",
    "fmi2SetReal",
    "fmi2GetReal",
    "fmi2DoStep",
)


def _probe(fmu: Path, workdir: Path) -> str | None:
    with zipfile.ZipFile(fmu) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
        cs = root.find("CoSimulation")
        if cs is None:
            return "modelDescription.xml has no CoSimulation element"
        ident = cs.get("modelIdentifier", "")
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", ident):
            return f"modelIdentifier {ident!r} is not a valid C identifier"
        members = [n for n in zf.namelist() if n.startswith("binaries/linux64/") and n[-1] != "/"]
        if f"binaries/linux64/{ident}.so" not in members:
            return f"binaries/linux64/{ident}.so is missing"
        for name in members:
            target = workdir / Path(name).name
            with zf.open(name) as src, open(target, "wb") as out:
                shutil.copyfileobj(src, out)
    try:
        lib = ctypes.CDLL(str(workdir / f"{ident}.so"))
    except OSError as exc:
        return f"binaries/linux64/{ident}.so does not load: {exc}"
    missing = [name for name in REQUIRED if not hasattr(lib, name)]
    if missing:
        return f"binaries/linux64/{ident}.so does not export {', '.join(missing)}"
    lib.fmi2GetVersion.restype = ctypes.c_char_p
    version = lib.fmi2GetVersion()
    if version != b"2.0":
        return f"fmi2GetVersion() of binaries/linux64/{ident}.so returns {version!r}, not '2.0'"
    return None


def main(argv: list[str]) -> int:
    """Probe the FMU ``argv[1]`` within ``argv[2]`` MiB of address space."""
    limit = int(argv[2]) * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    with tempfile.TemporaryDirectory(prefix="fmuid-probe-") as workdir:
        try:
            problem = _probe(Path(argv[1]), Path(workdir))
        except (zipfile.BadZipFile, ET.ParseError, OSError, KeyError, MemoryError) as exc:
            problem = f"cannot be unpacked: {exc}"
    if problem:
        sys.stderr.write(problem + "\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
