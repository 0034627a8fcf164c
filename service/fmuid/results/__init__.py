"""Saved results back as result objects (``load_result``); their tables are ``to_frame``.

A result JSON names its kind (``"kind"``: ``fit``, ``profile``, ``diagnose``, ``design``) and
the version of its schema (``"schema_version"``); it is checked against the kind's schema
(:mod:`fmuid.results.schema`) and built from it. A file written before these fields existed
(version 0) is read by its keys: ``designs`` (design), ``mismatch`` (diagnose), ``thresholds``
(profile), else ``parameters`` with ``chi2`` (fit).
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from fmuid.discrepancy.residual_tests import TestResult, Window
from fmuid.discrepancy.result import (
    AddedEstimate,
    CandidateScore,
    Diagnosis,
    EffectStep,
    StageCost,
)
from fmuid.discrepancy.schema import AddedOut, DiagnosisOut, EvidenceOut
from fmuid.discrepancy.words import RENAMED, RENAMED_PARAMETERS
from fmuid.errors import SpecError
from fmuid.estimation.result import Cost, FitResult
from fmuid.estimation.schema import SCHEMA_VERSION, FitResultOut, ValidationOut, read_model
from fmuid.estimation.validation import ValidationEntry
from fmuid.profiling.result import ParameterProfile, ProfilePoint, ProfileQuality, ProfileResult
from fmuid.profiling.schema import (
    ProfileParameterOut,
    ProfilePointOut,
    ProfileResultOut,
    QualityOut,
)
from fmuid.provenance import read
from fmuid.results.schema import KINDS

logger = logging.getLogger(__name__)


def load_result(path: str | Path) -> Any:
    """Read a result JSON written by ``fmuid fit/profile/diagnose/design`` or ``to_dict``.

    Parameters
    ----------
    path
        The JSON file.

    Returns
    -------
    FitResult, ProfileResult, Diagnosis or the design result
        Equal to the saved result in everything its JSON holds: ``load_result(p).to_dict()``
        is the saved JSON (with ``kind`` and ``schema_version`` added to a file written before
        they existed). What the JSON leaves out (the fit's Jacobian) is empty.

    Raises
    ------
    SpecError
        If the file is missing, is not JSON, or is no fmuid result (the message says why).

    """
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise SpecError(f"{path}: cannot read a result JSON ({exc})") from exc
    if not isinstance(data, dict):
        raise SpecError(f"{path}: a result JSON is an object, not {type(data).__name__}")
    try:
        return result_from_dict(data)
    except KeyError as exc:
        raise SpecError(f"{path}: not a complete fmuid result: missing key {exc}") from exc
    except ValidationError as exc:
        raise SpecError(f"{path}: not a complete fmuid result: {_problems(exc)}") from exc
    except (TypeError, ValueError) as exc:
        raise SpecError(f"{path}: not a complete fmuid result: {exc}") from exc


SHOWN = 6
"""Problems of a result JSON named in the error; the rest are counted."""


def _problems(exc: ValidationError) -> str:
    """Return the schema's complaints in one line: each field's path and what is wrong."""
    parts = []
    for e in exc.errors()[:SHOWN]:
        where = ".".join(str(x) for x in e["loc"])
        if e["type"] == "missing":
            parts.append(f"missing key '{e['loc'][-1]}' ({where})")
        else:
            parts.append(f"{where}: {e['msg']}")
    more = len(exc.errors()) - SHOWN
    return "; ".join(parts) + (f"; and {more} more" if more > 0 else "")


def kind_of(data: dict[str, Any]) -> str:
    """Return the kind of a result's JSON: its ``kind``, else guessed from its keys (version 0).

    Raises
    ------
    SpecError
        If ``kind`` names no result kind, or a JSON without it has none of the kinds' keys.

    """
    if "kind" in data:
        if data["kind"] not in KINDS:
            raise SpecError(
                f"result kind {data['kind']!r} is unknown; the kinds: {', '.join(KINDS)}"
            )
        return str(data["kind"])
    if "designs" in data:
        return "design"
    if "mismatch" in data:
        return "diagnose"
    if "thresholds" in data:
        return "profile"
    if "parameters" in data and "chi2" in data:
        return "fit"
    raise SpecError(
        "not an fmuid result: no 'kind', and not the keys of a fit (parameters, chi2), profile "
        f"(thresholds), diagnose (mismatch) or design (designs) result; got {sorted(data)}"
    )


def current(data: dict[str, Any]) -> dict[str, Any]:
    """Return a result's JSON in the current schema: ``kind`` and ``schema_version`` set.

    A file of version 0 (without them) gets its kind from its keys; a diagnosis' effect and
    parameter names of earlier versions become today's (``sensor_lag`` as ``output_lag``).
    """
    kind = kind_of(data)
    if kind == "diagnose":
        data = _renamed(data)
    version = data.get("schema_version", 0)
    if isinstance(version, int) and version > SCHEMA_VERSION:
        logger.warning(
            "result schema version %s is newer than this fmuid's %s: fields it does not know "
            "are left out",
            version,
            SCHEMA_VERSION,
        )
    return {**data, "kind": kind, "schema_version": version}


def result_from_dict(data: dict[str, Any]) -> Any:
    """Build the result object of a result's JSON form (see :func:`load_result`).

    Raises
    ------
    SpecError
        If the JSON is of no result kind.
    pydantic.ValidationError
        (a ``ValueError``) if it does not match its kind's schema, naming the field.

    """
    data = current(data)
    return _BUILDERS[data["kind"]](data)


def known(data: dict[str, Any]) -> dict[str, Any]:
    """Return a result's JSON as its kind's schema reads it (fields of another version dropped).

    Raises
    ------
    pydantic.ValidationError
        If it does not match its kind's schema, naming the field.

    """
    data = current(data)
    return dict(read_model(KINDS[data["kind"]], data).model_dump(mode="json", exclude_unset=True))


def _design_from_dict(data: dict[str, Any]) -> Any:
    # imported on first use: the design package is only needed for design results
    from fmuid.experiment_design.result import DesignResult

    return DesignResult.from_dict(known(data))


def _cost(data: dict[str, Any] | None) -> Cost:
    data = data or {}
    return Cost(int(data.get("simulations", 0)), float(data.get("seconds", 0.0)))


def fit_from_dict(data: dict[str, Any]) -> FitResult:
    """Build a :class:`FitResult` from ``FitResult.to_dict()`` (or a profile's JSON)."""
    data = current(data)
    model = ProfileResultOut if data["kind"] == "profile" else FitResultOut
    m = read_model(model, data)
    return _fit(m, m.model_dump(mode="json", exclude_unset=True))


def _fit(m: FitResultOut | ProfileResultOut, data: dict[str, Any]) -> FitResult:
    """Build the fit of a validated fit or profile JSON (``data``: the fields kept as saved)."""
    params = m.parameters
    names = tuple(params)
    fmu = {k: str(v) for k, v in data["fmu"].items() if k not in ("sha256", "model_name")}
    return FitResult(
        fmu_sha256=m.fmu.sha256,
        model_name=m.fmu.model_name,
        names=names,
        scales=tuple(params[n].scale for n in names),
        lower={n: params[n].lower for n in names},
        upper={n: params[n].upper for n in names},
        estimates={n: params[n].estimate for n in names},
        chi2=m.chi2,
        n_data=m.n_data,
        sigma=dict(m.sigma),
        sigma_method=dict(m.sigma_method),
        jacobian=np.zeros((0, len(names))),
        fixed=dict(m.fixed) if isinstance(m, FitResultOut) else dict(data.get("fixed", {})),
        global_search=bool(data.get("global_search", True)),
        message=str(data.get("message", "")),
        cost=Cost(m.cost.simulations, m.cost.seconds),
        fmu_info=fmu,
        units={**m.units, **{n: params[n].unit for n in names if params[n].unit}},
        provenance=read(data),
        validation=tuple(_validation(v) for v in m.validation),
    )


def _validation(v: ValidationOut) -> ValidationEntry:
    fields = {k: x for k, x in v.fields().items() if k != "initial_states_method"}
    return ValidationEntry(**{**fields, "rms_by_step": tuple(v.rms_by_step)})


def _point(p: ProfilePointOut) -> ProfilePoint:
    return ProfilePoint(
        value=p.value,
        chi2=float("nan") if p.chi2 is None else p.chi2,
        params=dict(p.params),
        at_bound=tuple(p.at_bound),
        error=p.error,
    )


def _quality(q: QualityOut) -> ProfileQuality:
    fields = q.model_dump(exclude={"unsettled"})
    reasons = fields.pop("unsettled_reasons")
    return ProfileQuality(**fields, unsettled=tuple(reasons))


def _profile(name: str, p: ProfileParameterOut) -> ParameterProfile:
    return ParameterProfile(
        name=name,
        estimate=p.estimate,
        lower=p.lower,
        upper=p.upper,
        scale=p.scale,
        ci_simultaneous=p.ci.simultaneous,
        ci_pointwise=p.ci.pointwise,
        status=p.status,
        points=tuple(_point(q) for q in p.profile),
        limited_by=tuple(p.limited_by or ()),
        status_reason=p.status_reason,
        quality=_quality(p.quality),
    )


def profile_from_dict(data: dict[str, Any]) -> ProfileResult:
    """Build a :class:`ProfileResult` from ``ProfileResult.to_dict()``."""
    data = current(data)
    m = read_model(ProfileResultOut, data)
    data = m.model_dump(mode="json", exclude_unset=True)
    return ProfileResult(
        fit=_fit(m, data),
        confidence=m.confidence,
        thresholds={k: float(v) for k, v in data["thresholds"].items()},
        parameters={n: _profile(n, p) for n, p in m.parameters.items()},
        better_optimum_found=m.better_optimum_found,
        structural_check=dict(data["structural_check"]),
        cost=Cost(m.cost.simulations, m.cost.seconds),
        checks=dict(data.get("checks", {})),
        provenance=read(data),
    )


def _test(t: dict[str, Any]) -> TestResult:
    return TestResult(**EvidenceOut.model_validate(t).fields())


def _renamed(data: dict[str, Any]) -> dict[str, Any]:
    """Map the effect and parameter names of earlier versions to today's (as JSON text)."""
    text = json.dumps(data)
    for old, new in {**RENAMED, **RENAMED_PARAMETERS}.items():
        text = text.replace(f'"{old}"', f'"{new}"')
    return dict(json.loads(text))


def _step(e: dict[str, Any]) -> EffectStep:
    return EffectStep(
        e["effect"],
        e.get("label", e["effect"]),
        e.get("description", ""),
        {k: _added(v) for k, v in e.get("parameters", {}).items()},
        float(e["chi2_before"]),
        float(e["chi2_after"]),
        float(e["p_value"]),
        float(e.get("p_adjusted", e["p_value"])),
        e.get("coupling_error"),
        e.get("steps_per_sample"),
    )


def _added(v: dict[str, Any]) -> AddedEstimate:
    return AddedEstimate(**AddedOut.model_validate(v).fields())


def diagnosis_from_dict(data: dict[str, Any]) -> Diagnosis:
    """Build a :class:`Diagnosis` from ``Diagnosis.to_dict()`` (of this or an earlier version).

    Effect and parameter names of earlier versions read as today's (``sensor_lag`` as
    ``output_lag``, ``tau_sensor`` as ``tau_outputs``).
    """
    data = current(data)
    m = read_model(DiagnosisOut, data)
    data = m.model_dump(mode="json", exclude_unset=True)
    params = data.get("parameters", {})
    return Diagnosis(
        mismatch=bool(data["mismatch"]),
        false_alarm=float(data.get("false_alarm", 0.01)),
        evidence=tuple(_test(t) for t in data.get("evidence", ())),
        tests_before=tuple(_test(t) for t in data.get("tests_before", ())),
        tests_after=tuple(_test(t) for t in data.get("tests_after", ())),
        location=dict(data.get("location", {})),
        windows=tuple(
            Window(
                w["experiment"],
                w["output"],
                float(w["window"][0]),
                float(w["window"][1]),
                float(w["score"]),
            )
            for w in data.get("windows", ())
        ),
        effect=data.get("effect"),
        description=data.get("description", ""),
        candidates=tuple(CandidateScore(**c) for c in data.get("candidates", ())),
        added_parameters={k: _added(v) for k, v in data.get("added_parameters", {}).items()},
        chi2_before=float(data["chi2_before"]),
        chi2_after=float(data["chi2_after"]),
        n_data=int(data.get("n_data", 0)),
        lrt_p_value=data.get("lrt_p_value"),
        bic_before=float(data.get("bic_before", 0.0)),
        bic_after=float(data.get("bic_after", 0.0)),
        parameters_before={k: v["before"] for k, v in params.items() if v["before"] is not None},
        parameters_after={k: v["after"] for k, v in params.items() if v["after"] is not None},
        second_effect=data.get("second_effect"),
        indistinguishable=tuple(m.indistinguishable),
        generic_correction=m.generic_correction,
        absorbed=dict(m.absorbed),
        scan_p_value=data.get("scan_p_value"),
        fmu=dict(data.get("fmu", {})),
        cost=_cost(data.get("cost")),
        stages=tuple(
            StageCost(str(c["stage"]), int(c["simulations"]), float(c["seconds"]))
            for c in (data.get("cost") or {}).get("stages", ())
        ),
        units=dict(data.get("units", {})),
        discriminating_experiment=m.discriminating_experiment,
        effects=tuple(_step(e) for e in data.get("effects", ())),
        validation=tuple(_validation(ValidationOut(**v)) for v in data.get("validation", ())),
        provenance=read(data),
    )


_BUILDERS = {
    "fit": fit_from_dict,
    "profile": profile_from_dict,
    "diagnose": diagnosis_from_dict,
    "design": _design_from_dict,
}
