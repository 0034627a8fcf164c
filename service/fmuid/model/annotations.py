"""The ``fmuid`` vendor annotation of an FMU: what its ``modelDescription.xml`` tells fmuid.

An FMU may carry, beside its variables, a ``<VendorAnnotations>`` block for fmuid::

    <Tool name="fmuid"><Model>
      <Physics effect="..." description="..."><Parameter name="..." off="..." .../></Physics>
      <Role variable="u" role="steer"/>
      <Path label="vehicle CG" x="x_pos" y="y_pos"/>
    </Model></Tool>

(the built-in FMUs carry it, written from the ``fmuid`` block of their ``variables.json`` by
:mod:`fmuid.model.build`). :class:`~fmuid.model.fmu.FmuModel` parses it with the rest of
``modelDescription.xml``, once, into its ``annotation``; the functions here take that model (or,
for a caller holding only a file, the path, read then). Switchable physics and roles are read by
:mod:`fmuid.discrepancy.knowledge`; a ``Path`` names two position outputs that draw a planar
path together (y against x), read here by :func:`planar_paths`.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from fmuid.model.fmu import FmuModel

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlanarPath:
    """Two position outputs of an FMU that draw one path: ``y`` against ``x``."""

    label: str
    x: str
    y: str


def fmuid_annotation_of(root: Any) -> Any:
    """Return the ``<Model>`` element of the ``fmuid`` annotation under a parsed description.

    ``root`` is the root element (lxml's or the standard library's) or None; so is the result.
    """
    if root is None:
        return None
    return root.find("VendorAnnotations/Tool[@name='fmuid']/Model")


def fmuid_annotation(fmu: FmuModel | str | Path) -> Any:
    """Return the ``<Model>`` element of the FMU's ``fmuid`` annotation, or None when it has none.

    A model gives the annotation it parsed; a path is read now (an unreadable
    ``modelDescription.xml`` is logged and treated as no annotation: the FMU stays usable
    without it).
    """
    if not isinstance(fmu, str | Path):
        return fmu.annotation
    try:
        with zipfile.ZipFile(fmu) as archive:
            root = ET.fromstring(archive.read("modelDescription.xml"))
    except (OSError, KeyError, zipfile.BadZipFile, ET.ParseError) as exc:
        log.warning("%s: no vendor annotations read: %s", fmu, exc)
        return None
    return fmuid_annotation_of(root)


def planar_paths(fmu: FmuModel | str | Path) -> tuple[PlanarPath, ...]:
    """Return the planar paths the FMU declares (none without an annotation).

    ``fmu`` is a parsed model (its annotation is not read again) or a file's path. A ``Path``
    element missing ``label``, ``x`` or ``y`` is logged and left out.
    """
    model = fmuid_annotation(fmu)
    paths = []
    for element in () if model is None else model.findall("Path"):
        a = element.attrib
        if not all(a.get(k) for k in ("label", "x", "y")):
            log.warning("%s: fmuid Path %s needs label, x and y: ignored", _name(fmu), a)
            continue
        paths.append(PlanarPath(a["label"], a["x"], a["y"]))
    return tuple(paths)


def _name(fmu: FmuModel | str | Path) -> str:
    return str(fmu if isinstance(fmu, str | Path) else fmu.path)
