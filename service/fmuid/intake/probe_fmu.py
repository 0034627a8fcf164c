"""Load an FMU's linux binary in a throw-away process and check its FMI 2.0/3.0 functions.

Run as a script (``python -I probe_fmu.py FMU MEMORY_MB TIMEOUT_S FMI_VERSION INTERFACE
MODEL_IDENTIFIER``) by :mod:`fmuid.intake.fmucheck`, which has parsed the FMU and hands on what the
probe needs from its model description, as the leader of its own process group; it imports only
the standard library so that it starts fast, and it limits its own memory, file sizes and time
(an alarm ends it) before touching the upload: loading a shared library runs its constructors,
which is native code from the uploader. Exit status 0 when the binary loads and exports every
function below; otherwise 1 with one line on stderr saying why.
"""

from __future__ import annotations

import ctypes
import re
import resource
import shutil
import signal
import sys
import tempfile
import zipfile
from pathlib import Path

COMMON = {
    "2.0": (
        "fmi2GetVersion",
        "fmi2Instantiate",
        "fmi2FreeInstance",
        "fmi2SetupExperiment",
        "fmi2EnterInitializationMode",
        "fmi2ExitInitializationMode",
        "fmi2Reset",
        "fmi2SetReal",
        "fmi2GetReal",
    ),
    "3.0": (
        "fmi3GetVersion",
        "fmi3FreeInstance",
        "fmi3EnterInitializationMode",
        "fmi3ExitInitializationMode",
        "fmi3Reset",
        "fmi3SetFloat64",
        "fmi3GetFloat64",
    ),
}
INTERFACE = {
    ("2.0", "CoSimulation"): ("fmi2DoStep",),
    ("2.0", "ModelExchange"): (
        "fmi2SetTime",
        "fmi2SetContinuousStates",
        "fmi2GetDerivatives",
        "fmi2NewDiscreteStates",
        "fmi2EnterContinuousTimeMode",
    ),
    ("3.0", "CoSimulation"): ("fmi3InstantiateCoSimulation", "fmi3DoStep"),
    ("3.0", "ModelExchange"): (
        "fmi3InstantiateModelExchange",
        "fmi3SetTime",
        "fmi3SetContinuousStates",
        "fmi3GetContinuousStateDerivatives",
        "fmi3UpdateDiscreteStates",
        "fmi3EnterContinuousTimeMode",
    ),
}
"""FMI functions the binary must export, by FMI version and the interface fmuid drives."""
BINARIES = {"2.0": "binaries/linux64", "3.0": "binaries/x86_64-linux"}


def _probe(fmu: Path, workdir: Path, version: str, kind: str, ident: str) -> str | None:
    if (version, kind) not in INTERFACE:
        return f"FMI {version} {kind} is not supported"
    with zipfile.ZipFile(fmu) as zf:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", ident):
            return f"modelIdentifier {ident!r} is not a valid C identifier"
        folder = BINARIES[version]
        members = [n for n in zf.namelist() if n.startswith(folder + "/") and n[-1] != "/"]
        if f"{folder}/{ident}.so" not in members:
            return f"{folder}/{ident}.so is missing"
        for name in members:
            target = workdir / Path(name).name
            with zf.open(name) as src, open(target, "wb") as out:
                shutil.copyfileobj(src, out)
    binary = f"{folder}/{ident}.so"
    try:
        lib = ctypes.CDLL(str(workdir / f"{ident}.so"))
    except OSError as exc:
        return f"{binary} does not load: {exc}"
    required = COMMON[version] + INTERFACE[(version, kind)]
    missing = [name for name in required if not hasattr(lib, name)]
    if missing:
        return f"{binary} does not export {', '.join(missing)}"
    get_version = getattr(lib, f"fmi{version[0]}GetVersion")
    get_version.restype = ctypes.c_char_p
    found = get_version()
    if not (found or b"").startswith(version[0].encode()):
        return f"fmi{version[0]}GetVersion() of {binary} returns {found!r}, not {version!r}"
    return None


def main(argv: list[str]) -> int:
    """Probe the FMU ``argv[1]`` within ``argv[2]`` MiB of address space and ``argv[3]`` s.

    ``argv[4:7]``: its FMI version, the interface fmuid drives, that interface's model
    identifier.
    """
    signal.alarm(int(argv[3]))
    limit = int(argv[2]) * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    with tempfile.TemporaryDirectory(prefix="fmuid-probe-") as workdir:
        try:
            problem = _probe(Path(argv[1]), Path(workdir), *argv[4:7])
        except (zipfile.BadZipFile, OSError, KeyError, MemoryError) as exc:
            problem = f"cannot be unpacked: {exc}"
    if problem:
        sys.stderr.write(problem + "\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
