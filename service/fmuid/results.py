"""Saved results back as result objects (``load_result``); their tables are ``to_frame``.

The kind of a result JSON is read from its shape: ``designs`` (design), ``mismatch``
(diagnose), ``thresholds`` (profile), else ``parameters`` with ``chi2`` (fit).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from fmuid.discrepancy.residual_tests import TestResult, Window
from fmuid.discrepancy.result import AddedEstimate, CandidateScore, Diagnosis, EffectStep
from fmuid.discrepancy.words import RENAMED, RENAMED_PARAMETERS
from fmuid.errors import SpecError
from fmuid.estimation.result import Cost, FitResult
from fmuid.profiling.result import ParameterProfile, ProfilePoint, ProfileQuality, ProfileResult
from fmuid.provenance import read


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
        is the saved JSON. What the JSON leaves out (the fit's Jacobian) is empty.

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
    except (TypeError, ValueError) as exc:
        raise SpecError(f"{path}: not a complete fmuid result: {exc}") from exc


def result_from_dict(data: dict[str, Any]) -> Any:
    """Build the result object of a result's JSON form (see :func:`load_result`)."""
    if "designs" in data:
        return _design_from_dict(data)
    if "mismatch" in data:
        return diagnosis_from_dict(data)
    if "thresholds" in data:
        return profile_from_dict(data)
    if "parameters" in data and "chi2" in data:
        return fit_from_dict(data)
    raise SpecError(
        "not an fmuid result: expected the keys of a fit (parameters, chi2), profile "
        f"(thresholds), diagnose (mismatch) or design (designs) result; got {sorted(data)}"
    )


def _design_from_dict(data: dict[str, Any]) -> Any:
    # imported on first use: the design package is only needed for design results
    from fmuid.experiment_design.result import DesignResult

    return DesignResult.from_dict(data)


def _cost(data: dict[str, Any] | None) -> Cost:
    data = data or {}
    return Cost(int(data.get("simulations", 0)), float(data.get("seconds", 0.0)))


def fit_from_dict(data: dict[str, Any]) -> FitResult:
    """Build a :class:`FitResult` from ``FitResult.to_dict()`` (or a profile's JSON)."""
    params = data["parameters"]
    fmu = dict(data.get("fmu", {}))
    names = tuple(params)
    return FitResult(
        fmu_sha256=fmu.pop("sha256", ""),
        model_name=fmu.pop("model_name", ""),
        names=names,
        scales=tuple(params[n].get("scale", "lin") for n in names),
        lower={n: float(params[n]["lower"]) for n in names},
        upper={n: float(params[n]["upper"]) for n in names},
        estimates={n: float(params[n]["estimate"]) for n in names},
        chi2=float(data["chi2"]),
        n_data=int(data["n_data"]),
        sigma={k: float(v) for k, v in data.get("sigma", {}).items()},
        sigma_method=dict(data.get("sigma_method", {})),
        jacobian=np.zeros((0, len(names))),
        fixed=dict(data.get("fixed", {})),
        global_search=bool(data.get("global_search", True)),
        message=str(data.get("message", "")),
        cost=_cost(data.get("cost")),
        fmu_info={k: str(v) for k, v in fmu.items()},
        units={
            **data.get("units", {}),
            **{n: params[n]["unit"] for n in names if params[n].get("unit")},
        },
        provenance=read(data),
    )


def _interval(pair: list[float | None]) -> tuple[float | None, float | None]:
    lo, hi = pair
    return (None if lo is None else float(lo), None if hi is None else float(hi))


def _point(p: dict[str, Any]) -> ProfilePoint:
    error = p.get("error")
    return ProfilePoint(
        value=float(p["value"]),
        chi2=float("nan") if p["chi2"] is None else float(p["chi2"]),
        params={k: float(v) for k, v in p.get("params", {}).items()},
        at_bound=tuple(p.get("at_bound", ())),
        error=error,
    )


def _quality(q: dict[str, Any]) -> ProfileQuality:
    return ProfileQuality(
        checks=int(q.get("checks", 0)),
        starts=int(q.get("starts", 0)),
        jumps=int(q.get("jumps", 0)),
        lower_valleys=int(q.get("lower_valleys", 0)),
        rewalks=int(q.get("rewalks", 0)),
        end_refits=int(q.get("end_refits", 0)),
        unsettled=tuple(q.get("unsettled_reasons", ())),
        check_simulations=int(q.get("check_simulations", 0)),
    )


def profile_from_dict(data: dict[str, Any]) -> ProfileResult:
    """Build a :class:`ProfileResult` from ``ProfileResult.to_dict()``."""
    fit = fit_from_dict(data)
    parameters = {}
    for name, p in data["parameters"].items():
        parameters[name] = ParameterProfile(
            name=name,
            estimate=float(p["estimate"]),
            lower=float(p["lower"]),
            upper=float(p["upper"]),
            scale=p.get("scale", "lin"),
            ci_simultaneous=_interval(p["ci"]["simultaneous"]),
            ci_pointwise=_interval(p["ci"]["pointwise"]),
            status=p["status"],
            points=tuple(_point(q) for q in p.get("profile", ())),
            limited_by=tuple(p.get("limited_by", ())),
            status_reason=p.get("status_reason", ""),
            quality=_quality(p.get("quality", {})),
        )
    return ProfileResult(
        fit=fit,
        confidence=float(data["confidence"]),
        thresholds={k: float(v) for k, v in data["thresholds"].items()},
        parameters=parameters,
        better_optimum_found=bool(data.get("better_optimum_found", False)),
        structural_check=dict(data.get("structural_check", {})),
        cost=_cost(data.get("cost")),
        checks=dict(data.get("checks", {})),
        provenance=read(data),
    )


def _test(t: dict[str, Any]) -> TestResult:
    return TestResult(
        t["test"],
        t.get("output"),
        t.get("experiment"),
        float(t["p_value"]),
        float(t.get("statistic", 0.0)),
        None if t.get("df") is None else float(t["df"]),
    )


def _renamed(data: dict[str, Any]) -> dict[str, Any]:
    """Map the effect and parameter names of earlier versions to today's (as JSON text)."""
    text = json.dumps(data)
    for old, new in {**RENAMED, **RENAMED_PARAMETERS}.items():
        text = text.replace(f'"{old}"', f'"{new}"')
    return dict(json.loads(text))


def _step(e: dict[str, Any]) -> EffectStep:
    return EffectStep(
        e["effect"], e.get("label", e["effect"]), e.get("description", ""),
        {k: _added(v) for k, v in e.get("parameters", {}).items()},
        float(e["chi2_before"]), float(e["chi2_after"]), float(e["p_value"]),
        float(e.get("p_adjusted", e["p_value"])), e.get("coupling_error"),
    )  # fmt: skip


def _added(v: dict[str, Any]) -> AddedEstimate:
    return AddedEstimate(
        float(v["estimate"]), _interval(v["ci"]), float(v["confidence"]), v.get("unit", ""),
        float(v["off"]), bool(v["excludes_off"]),
    )  # fmt: skip


def diagnosis_from_dict(data: dict[str, Any]) -> Diagnosis:
    """Build a :class:`Diagnosis` from ``Diagnosis.to_dict()`` (of this or an earlier version).

    Effect and parameter names of earlier versions read as today's (``sensor_lag`` as
    ``output_lag``, ``tau_sensor`` as ``tau_outputs``).
    """
    data = _renamed(data)
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
        indistinguishable=tuple(data.get("indistinguishable", ())),
        generic_correction=data.get("generic_correction"),
        absorbed=dict(data.get("absorbed", {})),
        scan_p_value=data.get("scan_p_value"),
        fmu=dict(data.get("fmu", {})),
        cost=_cost(data.get("cost")),
        units=dict(data.get("units", {})),
        discriminating_experiment=data.get("discriminating_experiment"),
        effects=tuple(_step(e) for e in data.get("effects", ())),
        validation=tuple(data.get("validation", ())),
        provenance=read(data),
    )
