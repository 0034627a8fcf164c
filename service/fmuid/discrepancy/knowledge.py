"""What the diagnosis knows of a model: its switchable physics and the roles of its variables.

Nothing here names a model. An FMU may declare, in the ``fmuid`` vendor annotation of its
``modelDescription.xml`` (read by :mod:`fmuid.model.annotations`), parameters whose default
value switches some physics off, and roles of its variables::

    <Tool name="fmuid"><Model>
      <Physics effect="side_slope" description="...">
        <Parameter name="slope" off="0" start="0" lower="-0.2" upper="0.2" scale="lin"
                   unit="rad" description="..."/>
      </Physics>
      <Role variable="u" role="steer"/>
    </Model></Tool>

(the built-in FMUs carry it, written from the ``fmuid`` block of their ``variables.json``). A
spec's ``physics`` adds to or overrides the FMU's declarations. ``vanishes="upper"`` marks a
parameter whose effect disappears as it grows without bound (a saturation angle), so that its
off value lies beyond the upper bound; otherwise the side follows from ``off`` and the bounds.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from fmuid.data import ParameterSpec, Spec
from fmuid.model.annotations import fmuid_annotation
from fmuid.model.fmu import FmuModel

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class AddedParameter:
    """A parameter that a candidate adds (switchable physics or a wrapper's parameter).

    Attributes
    ----------
    name, unit, meaning
        As reported.
    spec
        Start, bounds and scale for the fit.
    off
        The value at which the effect vanishes.
    off_side
        ``"inside"`` the bounds, ``"low"`` (below the lower bound, e.g. a time constant of 0 on
        a log scale) or ``"high"`` (the effect vanishes as the value grows).
    probe
        The screen's smallest effect (default: the bound next to off, or a step from off).
    grid
        Values the screen tries (default: spread over the bounds); a threshold's levels inside
        the range the signals reach, where it has an effect.

    """

    name: str
    unit: str
    meaning: str
    spec: ParameterSpec
    off: float
    off_side: str
    probe: float | None = None
    grid: tuple[float, ...] = ()


@dataclass(frozen=True)
class Physics:
    """One switchable effect of a model: its parameters and a sentence on what it does."""

    effect: str
    parameters: tuple[AddedParameter, ...]
    description: str


@dataclass(frozen=True)
class ModelKnowledge:
    """Switchable physics and variable roles of a model (from its FMU and the spec)."""

    physics: tuple[Physics, ...] = ()
    roles: tuple[tuple[str, str], ...] = ()

    def role(self, variable: str) -> str | None:
        """Role of a variable (e.g. ``"steer"``), if declared."""
        return dict(self.roles).get(variable)


def _side(off: float, lower: float, upper: float, vanishes: str | None) -> str:
    if vanishes == "upper":
        return "high"
    if vanishes == "lower" or off < lower:
        return "low"
    return "high" if off > upper else "inside"


def _parameter(element: ET.Element, where: str) -> AddedParameter:
    a = element.attrib
    try:
        bounds: dict[str, object] = {k: float(a[k]) for k in ("start", "lower", "upper")}
        spec = ParameterSpec.model_validate({**bounds, "scale": a.get("scale")})
        off = float(a["off"])
    except (KeyError, ValueError) as exc:
        raise ValueError(f"{where}: parameter {a.get('name')!r}: {exc}") from exc
    side = _side(off, spec.lower, spec.upper, a.get("vanishes"))
    return AddedParameter(a["name"], a.get("unit", ""), a.get("description", ""), spec, off, side)


def read_annotations(fmu: FmuModel | str | Path) -> ModelKnowledge:
    """Read the ``fmuid`` vendor annotation of an FMU (empty knowledge when it has none).

    ``fmu`` is a parsed model (its annotation is not read again) or a file's path. A malformed
    annotation is logged and ignored: the FMU stays usable without it.
    """
    fmu_path = getattr(fmu, "path", fmu)
    model = fmuid_annotation(fmu)
    if model is None:
        return ModelKnowledge()
    try:
        physics = tuple(
            Physics(
                p.attrib["effect"],
                tuple(_parameter(q, f"{fmu_path}") for q in p.findall("Parameter")),
                p.attrib.get("description", ""),
            )
            for p in model.findall("Physics")
        )
    except (KeyError, ValueError) as exc:
        log.warning("%s: fmuid annotation ignored: %s", fmu_path, exc)
        return ModelKnowledge()
    roles = tuple((r.attrib["variable"], r.attrib["role"]) for r in model.findall("Role"))
    return ModelKnowledge(physics, roles)


def model_knowledge(fmu: FmuModel | str | Path, spec: Spec) -> ModelKnowledge:
    """Return the FMU's declared knowledge with the spec's ``physics`` added (the spec wins)."""
    declared = read_annotations(fmu)
    physics = {p.effect: p for p in declared.physics}
    for effect, entry in spec.physics.items():
        params = tuple(
            AddedParameter(
                name,
                p.unit,
                p.description,
                ParameterSpec(start=p.start, lower=p.lower, upper=p.upper, scale=p.scale),
                p.off,
                _side(p.off, p.lower, p.upper, None),
            )
            for name, p in entry.parameters.items()
        )
        text = entry.description or f"the switchable physics '{effect}' is on"
        physics[effect] = Physics(effect, params, text)
    return ModelKnowledge(tuple(physics.values()), declared.roles)
