"""Checks of an uploaded FMU before a job that runs it is queued.

An FMU is a zip file with native code in it. Before it is stored for a job it must be a zip
within size limits (declared unpacked size, compression ratio, number of members), with no
member escaping the extraction folder (absolute paths, ``..``, symbolic links), FMI 2.0 or 3.0
with co-simulation or model exchange and a linux x86-64 binary
(:class:`fmuid.model.fmu.FmuModel`), every member intact (CRC), a ``modelDescription.xml``
within a size and a variable-count limit, and the binary must load and export the FMI functions
fmuid calls; the load is tried in a separate, memory- and time-limited process group
(:mod:`fmuid.intake.probe_fmu`) because loading a library runs its code, and the whole group is
killed afterwards, so that nothing a binary forks outlives the check.
"""

from __future__ import annotations

import stat
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile
import zlib
from pathlib import Path, PurePosixPath

from fmuid.data.limits import FmuLimits
from fmuid.errors import FmuError
from fmuid.model.fmu import FmuModel
from fmuid.processes import kill_group

MAX_MEMBERS = 10_000
MAX_RATIO = 200
"""Largest accepted compression ratio of one member bigger than 1 MiB (zip-bomb guard)."""
MODEL_DESCRIPTION = "modelDescription.xml"


def check_archive(path: Path, name: str, limits: FmuLimits) -> None:
    """Check the zip structure of an FMU without unpacking it.

    Parameters
    ----------
    path
        The uploaded file.
    name
        The name to quote in messages (the uploaded file name).
    limits
        The size limits.

    Raises
    ------
    FmuError
        Naming the first problem found.

    """
    max_unpacked_bytes = limits.max_fmu_unpacked_bytes
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
    description = next((info for info in infos if info.filename == MODEL_DESCRIPTION), None)
    if description is None:
        raise FmuError(f"{name}: no modelDescription.xml at the top of the archive")
    if description.file_size > limits.max_model_description_bytes:
        raise FmuError(
            f"{name}: modelDescription.xml unpacks to {description.file_size} bytes, more than"
            f" the limit of {limits.max_model_description_bytes}"
            " (FMUID_MAX_MODEL_DESCRIPTION_BYTES)"
        )
    _check_intact(path, name)


def _check_intact(path: Path, name: str) -> None:
    """Unpack every member once (to nowhere) and check its CRC."""
    try:
        with zipfile.ZipFile(path) as zf:
            bad = zf.testzip()
    except (zipfile.BadZipFile, zlib.error, OSError, EOFError, NotImplementedError) as exc:
        raise FmuError(f"{name}: a member of the archive is corrupt or unreadable: {exc}") from exc
    if bad is not None:
        raise FmuError(f"{name}: member {bad!r} is corrupt (its CRC-32 does not match)")


def count_variables(path: Path, name: str, limit: int) -> int:
    """Count the variables of ``modelDescription.xml`` by streaming it, stopping past ``limit``.

    Raises
    ------
    FmuError
        When the XML is not well-formed or lists more than ``limit`` variables.

    """
    count = 0
    depth = 0
    variables_depth = -1
    try:
        with zipfile.ZipFile(path) as zf, zf.open(MODEL_DESCRIPTION) as stream:
            for event, element in ET.iterparse(stream, events=("start", "end")):
                if event == "end":
                    depth -= 1
                    if depth == variables_depth:
                        variables_depth = -1
                    element.clear()
                    continue
                if depth == variables_depth + 1 and variables_depth >= 0:
                    count += 1
                    if count > limit:
                        raise FmuError(
                            f"{name}: modelDescription.xml lists more than the limit of {limit}"
                            " variables (FMUID_MAX_MODEL_VARIABLES)"
                        )
                if element.tag == "ModelVariables":
                    variables_depth = depth
                depth += 1
    except ET.ParseError as exc:
        raise FmuError(f"{name}: modelDescription.xml is not well-formed XML: {exc}") from exc
    return count


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


def probe_binary(model: FmuModel, name: str, limits: FmuLimits) -> None:
    """Load the FMU's linux64 binary in its own process group and check its FMI functions.

    The probe gets the FMI version, interface and model identifier of the parsed ``model``.

    The group is killed when the probe ends, in time or not, so that whatever the binary forked
    ends with it.

    Raises
    ------
    FmuError
        When the binary does not load, lacks an FMI function, crashes or hangs on load.

    """
    script = Path(__file__).with_name("probe_fmu.py")
    timeout = limits.probe_timeout_s
    command = [sys.executable, "-I", str(script), str(model.path), str(limits.probe_memory_mb)]
    described = [model.fmi_version, model.interface, model.model_identifier]
    with tempfile.TemporaryFile("w+") as errors:
        proc = subprocess.Popen(
            [*command, str(max(1, round(timeout))), *described],
            stdout=subprocess.DEVNULL,
            stderr=errors,
            process_group=0,
        )
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired as exc:
            raise FmuError(
                f"{name}: loading its binary did not finish within {timeout:g} s"
                " (FMUID_PROBE_TIMEOUT_S)"
            ) from exc
        finally:
            _kill_group(proc)
        errors.seek(0)
        stderr = errors.read(100_000)
    if proc.returncode < 0:
        raise FmuError(f"{name}: its binary crashed while loading (signal {-proc.returncode})")
    if proc.returncode != 0:
        reason = stderr.strip().splitlines()[-1] if stderr.strip() else "unknown"
        raise FmuError(f"{name}: {reason}")


def _kill_group(proc: subprocess.Popen[bytes]) -> None:
    """Kill the probe's process group (the probe and anything it forked) and reap the probe."""
    kill_group(proc.pid)
    proc.wait()


def check_fmu(path: Path, name: str, limits: FmuLimits) -> FmuModel:
    """Run every check on an uploaded FMU and return the parsed model.

    Parameters
    ----------
    path
        The uploaded file.
    name
        The name to quote in messages (the uploaded file name).
    limits
        The limits of the checks.

    Raises
    ------
    FmuError
        Naming the problem: not a zip, too big unpacked, zip bomb, a corrupt member, a path
        escaping the extraction folder, a model description over its limits, not FMI 2.0 or
        3.0, neither co-simulation nor model exchange, no linux x86-64 binary, a binary that
        does not load.

    """
    check_archive(path, name, limits)
    count_variables(path, name, limits.max_model_variables)
    try:
        model = FmuModel(path)
    except FmuError as exc:
        message = str(exc).replace(f"{path}: ", "").replace(str(path), "the upload")
        raise FmuError(f"{name}: {message}", exc.function, exc.status) from exc
    probe_binary(model, name, limits)
    return model
