"""SSP 2.0 parameter values (SSV): a fitted parameter set out, start values in.

The file is an ``ssv:ParameterSet`` (SSP 2.0 keeps the ``SSP1`` namespaces) with one
``ssv:Parameter`` per free and fixed FMU parameter, its value as ``ssv:Real`` (``ssv:Boolean``,
``ssv:String``) with the FMU's unit, the units' SI exponents in ``ssv:Units``, and what has no
SSV element (bounds, scale, intervals, label) in ``ssv:Annotations/ssc:Annotation`` of type
``org.fmuid.estimate`` (per parameter) and ``org.fmuid.study`` (per set). See docs/formats.md.
"""

from __future__ import annotations

import json
import logging
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fmuid.data import Spec, spec_from_json
from fmuid.errors import DataError, SpecError
from fmuid.formats._common import finite_number

logger = logging.getLogger(__name__)

SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
FMUID = "urn:fmuid:ssv-annotation:1"
ESTIMATE_TYPE = "org.fmuid.estimate"
STUDY_TYPE = "org.fmuid.study"
BASE_UNITS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")

ET.register_namespace("ssv", SSV)
ET.register_namespace("ssc", SSC)
ET.register_namespace("fmuid", FMUID)


@dataclass(frozen=True)
class SsvEstimate:
    """What an ``org.fmuid.estimate`` annotation says about one parameter.

    Attributes
    ----------
    role
        ``"free"`` (fitted) or ``"fixed"``.
    lower, upper, scale
        Bounds and fitting scale of a free parameter (``None`` when not given).
    intervals
        ``"simultaneous"``/``"pointwise"`` -> (lower end, upper end); ``None`` for an open end.
    confidence
        Level of the intervals.
    status, status_reason
        Identifiability label and why.

    """

    role: str
    lower: float | None = None
    upper: float | None = None
    scale: str | None = None
    intervals: dict[str, tuple[float | None, float | None]] = field(default_factory=dict)
    confidence: float | None = None
    status: str = ""
    status_reason: str = ""


@dataclass(frozen=True)
class ParameterSet:
    """The content of an SSV file.

    Attributes
    ----------
    name
        The set's name.
    values
        Parameter name -> value (float, bool or str), in the file's order.
    units
        Parameter name -> unit, where the file gives one.
    estimates
        Parameter name -> what fmuid's annotation says (absent for files of other tools).
    study
        Attributes of the ``org.fmuid.study`` annotation (model, sha256, chi2, ...).

    """

    name: str
    values: dict[str, float | bool | str]
    units: dict[str, str] = field(default_factory=dict)
    estimates: dict[str, SsvEstimate] = field(default_factory=dict)
    study: dict[str, str] = field(default_factory=dict)


def write_ssv(
    result: Any,
    path: str | os.PathLike[str],
    *,
    unit_definitions: Mapping[str, Mapping[str, float]] | None = None,
    name: str | None = None,
) -> Path:
    """Write a fit or profile result as an SSP 2.0 parameter-value file.

    Parameters
    ----------
    result
        A ``FitResult``, ``ProfileResult`` or their JSON form (``to_dict()`` or a file's content).
    path
        The ``.ssv`` file to write.
    unit_definitions
        Unit name -> SI exponents (``kg``, ``m``, ``s``, ``A``, ``K``, ``mol``, ``cd``, ``rad``,
        ``factor``, ``offset``), e.g. from :func:`fmu_unit_definitions`. A unit without a
        definition is written without ``ssv:Units`` entry and logged.
    name
        Name of the parameter set; default ``<model> estimates``.

    Returns
    -------
    Path
        The file written.

    """
    d = result_json(result)
    units: dict[str, str] = dict(d.get("units") or {})
    model = (d.get("fmu") or {}).get("model_name", "model")
    root = ET.Element(f"{{{SSV}}}ParameterSet", version="2.0", name=name or f"{model} estimates")
    params = ET.SubElement(root, f"{{{SSV}}}Parameters")
    used: set[str] = set()
    for pname, entry in d["parameters"].items():
        if not isinstance(entry, Mapping) or "estimate" not in entry:
            raise DataError(f"parameter '{pname}' has no estimate: not a fit or profile result")
        unit = units.get(pname)
        element = _parameter(params, pname, float(entry["estimate"]), unit)
        used |= {unit} if unit else set()
        _estimate_annotation(element, "free", entry, d.get("confidence"))
    for pname, value in (d.get("fixed") or {}).items():
        unit = units.get(pname) if not isinstance(value, str | bool) else None
        element = _parameter(params, pname, value, unit)
        used |= {unit} if unit else set()
        _estimate_annotation(element, "fixed", {}, None)
    defined = [u for u in sorted(used) if unit_definitions and u in unit_definitions]
    missing = sorted(used - set(defined))
    if missing:
        logger.warning("no SI definition for unit(s) %s: left out of ssv:Units", missing)
    if defined:
        unit_list = ET.SubElement(root, f"{{{SSV}}}Units")
        for unit in defined:
            exps = (unit_definitions or {})[unit]
            u = ET.SubElement(unit_list, f"{{{SSC}}}Unit", name=unit)
            ET.SubElement(
                u, f"{{{SSC}}}BaseUnit", {k: _num(v) for k, v in exps.items() if _non_default(k, v)}
            )
    study = {
        "model": model,
        "sha256": (d.get("fmu") or {}).get("sha256", ""),
        "chi2": _num(d.get("chi2")),
        "nData": _num(d.get("n_data")),
        "sigma": json.dumps(d.get("sigma") or {}),
    }
    annotations = ET.SubElement(root, f"{{{SSV}}}Annotations")
    annotation = ET.SubElement(annotations, f"{{{SSC}}}Annotation", type=STUDY_TYPE)
    ET.SubElement(annotation, f"{{{FMUID}}}Study", {k: v for k, v in study.items() if v})
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    ET.indent(root)
    ET.ElementTree(root).write(out, encoding="UTF-8", xml_declaration=True)
    return out


def result_json(result: Any) -> dict[str, Any]:
    """Return the JSON form of a fit or profile result, with the fit's scales and fixed values."""
    if isinstance(result, Mapping):
        return dict(result)
    d: dict[str, Any] = result.to_dict()
    fit = getattr(result, "fit", None)
    if fit is not None:
        fit_params = fit.to_dict()["parameters"]
        d["fixed"] = fit.to_dict()["fixed"]
        for pname, entry in d["parameters"].items():
            entry.setdefault("scale", fit_params[pname]["scale"])
    return d


def fmu_unit_definitions(fmu: str | os.PathLike[str]) -> dict[str, dict[str, float]]:
    """Return the SI exponents of every unit an FMU's ``modelDescription.xml`` defines."""
    from fmuid.model.fmu import FmuModel

    out: dict[str, dict[str, float]] = {}
    for unit in FmuModel(Path(fmu)).model_description.unitDefinitions:
        if unit.name and unit.baseUnit is not None:
            b = unit.baseUnit
            out[unit.name] = {k: getattr(b, k) for k in (*BASE_UNITS, "factor", "offset")}
    return out


def _non_default(key: str, value: float) -> bool:
    return value != {"factor": 1.0}.get(key, 0)


def _num(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    return repr(float(value))  # type: ignore[arg-type]


def _parameter(
    parent: ET.Element, name: str, value: float | bool | str, unit: str | None
) -> ET.Element:
    element = ET.SubElement(parent, f"{{{SSV}}}Parameter", name=name)
    if isinstance(value, bool):
        ET.SubElement(element, f"{{{SSV}}}Boolean", value="true" if value else "false")
    elif isinstance(value, str):
        ET.SubElement(element, f"{{{SSV}}}String", value=value)
    else:
        attrs = {"value": _num(value), **({"unit": unit} if unit else {})}
        ET.SubElement(element, f"{{{SSV}}}Real", attrs)
    return element


def _estimate_annotation(
    element: ET.Element, role: str, entry: Mapping[str, Any], confidence: float | None
) -> None:
    attrs = {
        "role": role,
        "lower": _num(entry.get("lower")),
        "upper": _num(entry.get("upper")),
        "scale": entry.get("scale") or "",
        "status": entry.get("status") or "",
        "statusReason": entry.get("status_reason") or "",
    }
    annotations = ET.SubElement(element, f"{{{SSV}}}Annotations")
    annotation = ET.SubElement(annotations, f"{{{SSC}}}Annotation", type=ESTIMATE_TYPE)
    est = ET.SubElement(annotation, f"{{{FMUID}}}Estimate", {k: v for k, v in attrs.items() if v})
    for kind, ends in (entry.get("ci") or {}).items():
        ci = {"kind": kind, "confidence": _num(confidence)}
        ci |= {side: _num(v) for side, v in zip(("lower", "upper"), ends, strict=True)}
        ET.SubElement(est, f"{{{FMUID}}}Interval", {k: v for k, v in ci.items() if v})


def read_ssv(path: str | os.PathLike[str]) -> ParameterSet:
    """Read an SSV file (SSP 1.0 or 2.0): values, units and fmuid's annotations.

    Raises
    ------
    DataError
        If the file is not an ``ssv:ParameterSet`` or a value cannot be read, naming the file
        and the parameter.

    """
    source = Path(path)
    try:
        root = ET.parse(source).getroot()
    except (ET.ParseError, OSError) as exc:
        raise DataError(f"{source}: not a readable XML file: {exc}") from exc
    if root.tag != f"{{{SSV}}}ParameterSet":
        raise DataError(f"{source}: the root element is {root.tag}, not ssv:ParameterSet")
    values: dict[str, float | bool | str] = {}
    units: dict[str, str] = {}
    estimates: dict[str, SsvEstimate] = {}
    for p in root.iterfind(f"{{{SSV}}}Parameters/{{{SSV}}}Parameter"):
        pname = p.get("name") or ""
        typed = next((c for c in p if c.tag.startswith(f"{{{SSV}}}")), None)
        if not pname or typed is None or typed.get("value") is None:
            raise DataError(f"{source}: parameter '{pname}' has no name or no typed value")
        values[pname] = _value(source, pname, typed)
        if typed.get("unit"):
            units[pname] = typed.get("unit") or ""
        est = _annotation(p, ESTIMATE_TYPE)
        if est is not None:
            estimates[pname] = _read_estimate(est)
    study = _annotation(root, STUDY_TYPE)
    return ParameterSet(
        root.get("name") or source.stem,
        values,
        units,
        estimates,
        dict(study.attrib) if study is not None else {},
    )


def _annotation(element: ET.Element, kind: str) -> ET.Element | None:
    """First child of the annotation of type ``kind`` (``ssv:Annotations``; SSP 1.0: ``ssc:``)."""
    for ns in (SSV, SSC):
        found = element.find(f"{{{ns}}}Annotations/{{{SSC}}}Annotation[@type='{kind}']/")
        if found is not None:
            return found
    return None


def _value(source: Path, name: str, typed: ET.Element) -> float | bool | str:
    kind = typed.tag.split("}")[1]
    text = typed.get("value") or ""
    if kind == "String" or kind == "Enumeration":
        return text
    if kind == "Boolean":
        if text not in ("true", "false", "1", "0"):
            raise DataError(f"{source}: parameter '{name}': {text!r} is not a Boolean")
        return text in ("true", "1")
    return finite_number(text, f"{source}: parameter '{name}'")


def _opt(element: ET.Element, key: str) -> float | None:
    text = element.get(key)
    return None if text is None else float(text)


def _read_estimate(est: ET.Element) -> SsvEstimate:
    intervals = {
        ci.get("kind") or "": (_opt(ci, "lower"), _opt(ci, "upper"))
        for ci in est.iterfind(f"{{{FMUID}}}Interval")
    }
    first = est.find(f"{{{FMUID}}}Interval")
    return SsvEstimate(
        role=est.get("role") or "free",
        lower=_opt(est, "lower"),
        upper=_opt(est, "upper"),
        scale=est.get("scale"),
        intervals=intervals,
        confidence=None if first is None else _opt(first, "confidence"),
        status=est.get("status") or "",
        status_reason=est.get("statusReason") or "",
    )


def with_start_values(spec: Spec, values: Mapping[str, float | bool | str], source: str) -> Spec:
    """Return ``spec`` with free parameters starting at ``values`` and the other values fixed.

    Parameters
    ----------
    spec
        The study.
    values
        Parameter values, e.g. :attr:`ParameterSet.values`.
    source
        Where the values come from, for error messages.

    Raises
    ------
    SpecError
        If a free parameter's value is not a number or lies outside its bounds.

    """
    data = spec.model_dump(exclude_none=True)
    for name, value in values.items():
        if name in spec.parameters:
            if isinstance(value, bool | str):
                raise SpecError(f"{source}: free parameter '{name}' needs a number, not {value!r}")
            data["parameters"][name]["start"] = float(value)
        else:
            data["fixed"][name] = value
    return spec_from_json(json.dumps(data), f"{spec.source} with start values from {source}")
