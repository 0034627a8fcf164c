"""A loaded FMU: checks it is FMI 2.0 co-simulation for linux64 and lists its variables."""

from __future__ import annotations

import hashlib
import logging
import posixpath
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass
from pathlib import Path

import fmpy
from fmpy.model_description import ModelDescription

from fmuid.errors import FmuError

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Variable:
    """One real scalar variable of an FMU, with its FMI names.

    Attributes
    ----------
    name
        Variable name in ``modelDescription.xml``.
    value_reference
        FMI value reference.
    causality
        ``parameter``, ``input``, ``output``, ...
    variability
        ``tunable``, ``fixed``, ``continuous``, ...
    start
        Start value, or None when the FMU gives none.
    unit
        Unit name, or None.
    description
        Free text (may be empty).

    """

    name: str
    value_reference: int
    causality: str
    variability: str
    start: float | None
    unit: str | None
    description: str


def _check_archive(path: Path) -> set[str]:
    if not path.is_file():
        raise FmuError(f"FMU {path} does not exist")
    if not zipfile.is_zipfile(path):
        raise FmuError(f"{path} is not an FMU: it is not a zip archive")
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
    except (zipfile.BadZipFile, OSError) as exc:
        raise FmuError(f"{path} is not a readable zip archive: {exc}") from exc
    for name in names:
        normalized = posixpath.normpath(name.replace("\\", "/"))
        if name.startswith(("/", "\\")) or normalized == ".." or normalized.startswith("../"):
            raise FmuError(f"{path}: archive entry {name!r} escapes the extraction directory")
        if len(name) > 1 and name[1] == ":":
            raise FmuError(f"{path}: archive entry {name!r} is an absolute Windows path")
    return set(names)


def _fmi_version(path: Path, names: set[str]) -> str:
    if "modelDescription.xml" not in names:
        raise FmuError(f"{path}: the FMU has no modelDescription.xml")
    try:
        with zipfile.ZipFile(path) as archive:
            root = ET.fromstring(archive.read("modelDescription.xml"))
    except ET.ParseError as exc:
        raise FmuError(f"{path}: modelDescription.xml is not valid XML: {exc}") from exc
    return root.get("fmiVersion", "unknown")


def _start(value: object) -> float | None:
    if value is None:
        return None
    try:
        return float(str(value))
    except ValueError:
        return None


class FmuModel:
    """An FMI 2.0 co-simulation FMU with a linux64 binary.

    Parameters
    ----------
    path
        The ``.fmu`` file.

    Attributes
    ----------
    path
        The ``.fmu`` file.
    sha256
        SHA-256 hex digest of the file.
    model_name, fmi_version, guid, model_identifier
        From ``modelDescription.xml``.
    model_description
        fmpy's parsed model description.
    parameters, inputs, outputs
        Real variables by name, in file order.

    Raises
    ------
    FmuError
        If the file is not a zip archive, has entries escaping the extraction directory, is not
        FMI 2.0, has no co-simulation interface or no ``binaries/linux64/<id>.so``.

    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        names = _check_archive(self.path)
        self.sha256 = hashlib.sha256(self.path.read_bytes()).hexdigest()
        version = _fmi_version(self.path, names)
        if version != "2.0":
            raise FmuError(f"{self.path}: FMI version {version} is not supported (only 2.0)")
        try:
            description = fmpy.read_model_description(str(self.path))
        except Exception as exc:  # fmpy raises bare Exception, lxml and KeyError subclasses
            raise FmuError(f"{self.path}: cannot read modelDescription.xml: {exc}") from exc
        if description.coSimulation is None:
            raise FmuError(f"{self.path}: the FMU has no co-simulation interface")
        self.model_description: ModelDescription = description
        self.model_name: str = description.modelName
        self.fmi_version: str = description.fmiVersion
        self.guid: str = description.guid
        self.model_identifier: str = description.coSimulation.modelIdentifier
        binary = f"binaries/linux64/{self.model_identifier}.so"
        if binary not in names:
            raise FmuError(f"{self.path}: the FMU has no linux64 binary ({binary} is missing)")
        self.parameters: dict[str, Variable] = {}
        self.inputs: dict[str, Variable] = {}
        self.outputs: dict[str, Variable] = {}
        groups = {"parameter": self.parameters, "input": self.inputs, "output": self.outputs}
        for v in description.modelVariables:
            group = groups.get(v.causality)
            if group is None:
                continue
            if v.type != "Real":
                logger.info(
                    "%s: %s variable %s ignored (only Real is supported)", self.path, v.type, v.name
                )
                continue
            unit = v.unit if v.unit else (v.declaredType.unit if v.declaredType else None)
            group[v.name] = Variable(
                name=v.name,
                value_reference=int(v.valueReference),
                causality=v.causality,
                variability=v.variability,
                start=_start(v.start),
                unit=unit or None,
                description=v.description or "",
            )

    @property
    def can_interpolate_inputs(self) -> bool:
        """Whether the FMU accepts first-order input derivatives (``canInterpolateInputs``)."""
        return bool(self.model_description.coSimulation.canInterpolateInputs)

    def __repr__(self) -> str:
        """Name, file and checksum prefix."""
        return f"FmuModel({self.model_name!r}, path={str(self.path)!r}, sha256={self.sha256[:12]})"
