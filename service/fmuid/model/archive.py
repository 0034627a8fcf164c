"""An FMU file read once: its bytes, its zip opened once in memory, its description parsed once.

:func:`open_archive` reads the file and opens its zip directory on the bytes in memory (the
model keeps it: simulators unpack their copies from it). :func:`read_description` parses
``modelDescription.xml`` once.

fmpy reads a model description from an FMU by opening the zip again and parsing the XML into
objects it keeps, dropping the tree; fmuid also needs the tree (the FMI version before fmpy
judges it, and the ``fmuid`` vendor annotation, which fmpy does not keep). So that the XML is
parsed once, :func:`read_description` hands fmpy the XML bytes already read from the archive
(as a temporary ``.xml`` file: fmpy's reader takes no bytes but a zip) and, for that one call,
makes lxml's default parser of this thread (:func:`lxml.etree.set_default_parser`, which is
per thread) one that builds the tree fmpy reads and keeps its root for the caller.
"""

from __future__ import annotations

import io
import posixpath
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import fmpy
from fmpy.model_description import ModelDescription
from lxml import etree

from fmuid.errors import FmuError

MODEL_DESCRIPTION = "modelDescription.xml"
SUPPORTED = ("2.0", "3.0")
"""The FMI versions fmuid runs."""


@dataclass(frozen=True)
class Archive:
    """What one read of an FMU file gives: its bytes, the zip opened on them, the description."""

    data: bytes
    zip: zipfile.ZipFile
    """The archive, opened once on ``data`` (in memory); simulators extract it from here."""
    xml: bytes | None
    """``modelDescription.xml``, or None when the archive has none."""


def open_archive(path: Path) -> Archive:
    """Read the file once and open its zip directory once, in memory; check the entry names."""
    if not path.is_file():
        raise FmuError(f"FMU {path} does not exist")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise FmuError(f"FMU {path} cannot be read: {exc}") from exc
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        names = archive.namelist()
        _check_names(path, names)
        xml = archive.read(MODEL_DESCRIPTION) if MODEL_DESCRIPTION in names else None
    except zipfile.BadZipFile as exc:
        raise FmuError(f"{path} is not an FMU: it is not a zip archive ({exc})") from exc
    except OSError as exc:
        raise FmuError(f"{path} is not a readable zip archive: {exc}") from exc
    return Archive(data, archive, xml)


def _check_names(path: Path, names: list[str]) -> None:
    """Refuse entries that would escape the extraction directory."""
    for name in names:
        normalized = posixpath.normpath(name.replace("\\", "/"))
        if name.startswith(("/", "\\")) or normalized == ".." or normalized.startswith("../"):
            raise FmuError(f"{path}: archive entry {name!r} escapes the extraction directory")
        if len(name) > 1 and name[1] == ":":
            raise FmuError(f"{path}: archive entry {name!r} is an absolute Windows path")


@dataclass(frozen=True)
class Description:
    """One parse of ``modelDescription.xml``."""

    fmpy: ModelDescription
    """fmpy's model description."""
    root: Any
    """The root element (lxml) of the document fmpy read."""
    fmi_version: str
    """``"2.0"`` or ``"3.0"``."""


class _KeptTree:
    """An lxml parser target that builds the tree and keeps its root (for one parse only)."""

    def __init__(self) -> None:
        self._builder = etree.TreeBuilder()
        self.root: Any = None

    def start(self, tag: str, attrib: dict[str, str], nsmap: Any = None) -> Any:
        return self._builder.start(tag, attrib, nsmap)

    def end(self, tag: str) -> Any:
        return self._builder.end(tag)

    def data(self, text: str) -> None:
        self._builder.data(text)

    def comment(self, text: str) -> Any:
        return self._builder.comment(text)

    def pi(self, target: str, text: str | None = None) -> Any:
        return self._builder.pi(target, text)

    def close(self) -> Any:
        etree.set_default_parser()  # the schemas fmpy parses next get lxml's own parser
        self.root = self._builder.close()
        return etree.ElementTree(self.root)


def _version(root: Any) -> str:
    version = str(root.get("fmiVersion", "unknown"))
    return "3.0" if version.startswith("3.") else version


def read_description(path: Path, xml: bytes | None) -> Description:
    """Parse ``xml`` (the ``modelDescription.xml`` of the FMU ``path``) once, with fmpy.

    Raises
    ------
    FmuError
        If there is no description, it is not XML, its FMI version is not 2.0 or 3.0, or fmpy
        cannot read it (naming the FMU and fmpy's reason).

    """
    if xml is None:
        raise FmuError(f"{path}: the FMU has no modelDescription.xml")
    kept = _KeptTree()
    etree.set_default_parser(etree.XMLParser(target=kept))
    try:
        with tempfile.NamedTemporaryFile(prefix="fmuid-", suffix=".xml") as file:
            file.write(xml)
            file.flush()
            description = fmpy.read_model_description(file.name)
    except etree.XMLSyntaxError as exc:
        raise FmuError(f"{path}: modelDescription.xml is not valid XML: {exc}") from exc
    except Exception as exc:  # fmpy raises bare Exception, lxml and KeyError subclasses
        version = "unknown" if kept.root is None else _version(kept.root)
        _check_version(path, version)
        raise FmuError(f"{path}: cannot read modelDescription.xml (FMI {version}): {exc}") from exc
    finally:
        etree.set_default_parser()
    version = _version(kept.root)
    _check_version(path, version)
    return Description(description, kept.root, version)


def _check_version(path: Path, version: str) -> None:
    if version not in SUPPORTED:
        raise FmuError(f"{path}: FMI version {version} is not supported (only 2.0 and 3.0)")
