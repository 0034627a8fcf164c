"""Checks of an uploaded FMU before a job that runs it is queued.

An FMU is a zip file with native code in it. Before it is stored for a job it must be a zip
within size limits (declared unpacked size, compression ratio, number of members), with no
member escaping the extraction folder (absolute paths, ``..``, symbolic links), FMI 2.0 or 3.0
with co-simulation or model exchange and a linux x86-64 binary
(:class:`fmuid.model.fmu.FmuModel`), and that binary must load and export the FMI functions
fmuid calls; the load is tried in a separate, memory-limited process
(:mod:`fmuid.jobs.probe_fmu`) because loading a library runs its code.
"""

from __future__ import annotations

import stat
import subprocess
import sys
import zipfile
from pathlib import Path, PurePosixPath

from fmuid.errors import FmuError
from fmuid.model.fmu import FmuModel

MAX_MEMBERS = 10_000
MAX_RATIO = 200
"""Largest accepted compression ratio of one member bigger than 1 MiB (zip-bomb guard)."""
PROBE_TIMEOUT_S = 30.0
PROBE_MEMORY_MB = 1024


def check_archive(path: Path, name: str, max_unpacked_bytes: int) -> None:
    """Check the zip structure of an FMU without unpacking it.

    Parameters
    ----------
    path
        The uploaded file.
    name
        The name to quote in messages (the uploaded file name).
    max_unpacked_bytes
        Largest accepted sum of the members' unpacked sizes [bytes].

    Raises
    ------
    FmuError
        Naming the first problem found.

    """
    if not zipfile.is_zipfile(path):
        raise FmuError(f"{name}: not a zip archive (an FMU is a zip file)")
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
    except (zipfile.BadZipFile, OSError) as exc:
        raise FmuError(f"{name}: not a readable zip archive: {exc}") from exc
    if len(infos) > MAX_MEMBERS:
        raise FmuError(f"{name}: {len(infos)} members, more than the limit of {MAX_MEMBERS}")
    total = 0
    for info in infos:
        _check_member_name(info, name)
        total += info.file_size
        if info.file_size > (1 << 20) and info.file_size > MAX_RATIO * max(info.compress_size, 1):
            raise FmuError(
                f"{name}: member {info.filename!r} unpacks {info.file_size} bytes from"
                f" {info.compress_size} (ratio over {MAX_RATIO}): refused as a zip bomb"
            )
    if total > max_unpacked_bytes:
        raise FmuError(
            f"{name}: unpacks to {total} bytes, more than the limit of {max_unpacked_bytes}"
            " (FMUID_MAX_FMU_UNPACKED_BYTES)"
        )
    if "modelDescription.xml" not in {info.filename for info in infos}:
        raise FmuError(f"{name}: no modelDescription.xml at the top of the archive")


def _check_member_name(info: zipfile.ZipInfo, name: str) -> None:
    member = info.filename
    path = PurePosixPath(member.replace("\\", "/"))
    if (
        path.is_absolute()
        or ".." in path.parts
        or "\x00" in member
        or (len(member) > 1 and member[1] == ":")
    ):
        raise FmuError(f"{name}: member {member!r} would be unpacked outside its folder")
    if stat.S_ISLNK(info.external_attr >> 16):
        raise FmuError(f"{name}: member {member!r} is a symbolic link")


def probe_binary(path: Path, name: str) -> None:
    """Load the FMU's linux64 binary in a separate process and check its FMI functions.

    Raises
    ------
    FmuError
        When the binary does not load, lacks an FMI function, crashes or hangs on load.

    """
    script = Path(__file__).with_name("probe_fmu.py")
    try:
        proc = subprocess.run(
            [sys.executable, "-I", str(script), str(path), str(PROBE_MEMORY_MB)],
            capture_output=True,
            text=True,
            timeout=PROBE_TIMEOUT_S,
            start_new_session=True,
        )
    except subprocess.TimeoutExpired as exc:
        raise FmuError(
            f"{name}: loading its binary did not finish within {PROBE_TIMEOUT_S:.0f} s"
        ) from exc
    if proc.returncode < 0:
        raise FmuError(f"{name}: its binary crashed while loading (signal {-proc.returncode})")
    if proc.returncode != 0:
        reason = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else "unknown"
        raise FmuError(f"{name}: {reason}")


def check_fmu(path: Path, name: str, max_unpacked_bytes: int) -> FmuModel:
    """Run every check on an uploaded FMU and return the parsed model.

    Parameters
    ----------
    path
        The uploaded file.
    name
        The name to quote in messages (the uploaded file name).
    max_unpacked_bytes
        Largest accepted sum of the members' unpacked sizes [bytes].

    Raises
    ------
    FmuError
        Naming the problem: not a zip, too big unpacked, zip bomb, a path escaping the
        extraction folder, not FMI 2.0 or 3.0, neither co-simulation nor model exchange, no linux
        x86-64 binary, a binary that does not load.

    """
    check_archive(path, name, max_unpacked_bytes)
    try:
        model = FmuModel(path)
    except FmuError as exc:
        message = str(exc).replace(f"{path}: ", "").replace(str(path), "the upload")
        raise FmuError(f"{name}: {message}", exc.function, exc.status) from exc
    probe_binary(path, name)
    return model
