"""Reading a PEtab-v2-style problem whose model is an FMU (see :mod:`fmuid.formats.petab`)."""

from __future__ import annotations

import csv
import json
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from fmuid.data import Experiment, experiment_from_arrays, spec_from_json
from fmuid.errors import DataError, SpecError
from fmuid.formats._common import finite_number
from fmuid.formats.petab import FILES, PLACEHOLDER, PetabProblem


def read_petab(problem_file: str | os.PathLike[str]) -> PetabProblem:
    """Read a PEtab-v2-style problem whose model is an FMU.

    Raises
    ------
    SpecError
        If the problem uses what fmuid cannot run (a model that is not an FMU, an observable
        formula that is not an FMU output name, a noise model other than normal), naming the
        file, row and column.
    DataError
        If a table is missing, or a cell is not a number.

    """
    path = Path(problem_file)
    try:
        problem = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise DataError(f"{path}: cannot read the problem file: {exc}") from exc
    if not isinstance(problem, dict) or "model_files" not in problem:
        raise SpecError(f"{path}: not a PEtab problem (no model_files)")
    base = path.parent
    models = problem["model_files"]
    if len(models) != 1:
        raise SpecError(f"{path}: model_files: fmuid runs exactly one model, not {len(models)}")
    (model,) = models.values()
    if str(model.get("language", "")).lower() != "fmu":
        raise SpecError(f"{path}: model_files: language {model.get('language')!r} is not 'fmu'")
    ext = (problem.get("extensions") or {}).get("fmuid") or {}
    tables = {k: _read_tables(base, problem, f"{k}_files") for k in FILES if k != "input"}
    tables["input"] = [r for f in ext.get("input_files") or [] for r in _read_tsv(base / f)]
    observables = {r["observableId"]: r for r in tables["observable"]}
    outputs, output_of, noise_params = _outputs(path, observables)
    parameters, fixed = _parameters(tables["parameter"], noise_params)
    fixed.update(_conditions(tables["condition"], tables["experiment"]))
    fixed.update(ext.get("fixed_text") or {})
    spec_data = {
        "parameters": parameters,
        "fixed": fixed,
        "inputs": list(ext.get("inputs") or []),
        "outputs": outputs,
        **{k: ext[k] for k in ("confidence", "global_search", "seed", "interface") if k in ext},
    }
    spec = spec_from_json(json.dumps(spec_data), str(path))
    experiments = _experiments(tables, outputs, output_of)
    return PetabProblem(base / model["location"], experiments, spec)


def _read_tables(base: Path, problem: Mapping[str, Any], key: str) -> list[dict[str, str]]:
    files = problem.get(key) or []
    return [
        row for f in ([files] if isinstance(files, str) else files) for row in _read_tsv(base / f)
    ]


def _read_tsv(path: Path) -> list[dict[str, str]]:
    try:
        with path.open(newline="") as handle:
            return [
                {k: (v or "").strip() for k, v in row.items()}
                for row in csv.DictReader(handle, delimiter="\t")
            ]
    except OSError as exc:
        raise DataError(f"{path}: cannot read the table: {exc}") from exc


def _outputs(
    path: Path, observables: Mapping[str, Mapping[str, str]]
) -> tuple[dict[str, dict[str, Any]], dict[str, str], set[str]]:
    """Return the outputs with their noise, each observable's output, the noise parameters."""
    outputs: dict[str, dict[str, Any]] = {}
    output_of: dict[str, str] = {}
    noise_params = set()
    for oid, row in observables.items():
        where = f"{path.parent / FILES['observable']}: observable {oid}"
        output = row.get("observableFormula", "")
        if not re.fullmatch(r"[A-Za-z_]\w*", output) or output in outputs:
            raise SpecError(
                f"{where}: observableFormula {output!r} must be the name of an FMU output, "
                "one observable per output (fmuid fits FMU outputs directly)"
            )
        output_of[oid] = output
        if (row.get("noiseDistribution") or "normal") != "normal":
            raise SpecError(
                f"{where}: noiseDistribution {row['noiseDistribution']!r} is not normal"
            )
        formula = row.get("noiseFormula", "")
        if formula == PLACEHOLDER.format(oid) or formula in (
            row.get("noisePlaceholders") or ""
        ).split(";"):
            sigma: float | str = "column"
        elif re.fullmatch(r"[A-Za-z_]\w*", formula):
            sigma = "estimate"
            noise_params.add(formula)
        else:
            sigma = finite_number(formula, f"{where}: noiseFormula")
        outputs[output] = {"sigma": sigma}
    return outputs, output_of, noise_params


def _parameters(
    rows: Sequence[Mapping[str, str]], noise_params: set[str]
) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
    free: dict[str, dict[str, Any]] = {}
    fixed: dict[str, Any] = {}
    for row in rows:
        pid = row["parameterId"]
        where = f"{FILES['parameter']}: parameter {pid}"
        if pid in noise_params:
            continue
        nominal = finite_number(row.get("nominalValue", ""), f"{where}: nominalValue")
        if row.get("estimate", "").lower() not in ("true", "1"):
            fixed[pid] = nominal
            continue
        scale = {"log10": "log", "log": "log", "lin": "lin", "": None}.get(
            row.get("parameterScale", "")
        )
        entry = {
            "start": nominal,
            "lower": finite_number(row.get("lowerBound", ""), f"{where}: lowerBound"),
            "upper": finite_number(row.get("upperBound", ""), f"{where}: upperBound"),
        }
        free[pid] = entry | ({"scale": scale} if scale else {})
    return free, fixed


def _conditions(
    conditions: Sequence[Mapping[str, str]], experiments: Sequence[Mapping[str, str]]
) -> dict[str, float]:
    used = {r.get("conditionId", "") for r in experiments} - {""}
    if len(used) > 1:
        raise SpecError(
            f"{FILES['experiment']}: experiments use different conditions "
            f"({', '.join(sorted(used))}); fmuid shares one set of fixed values across experiments"
        )
    return {
        r["targetId"]: finite_number(r["targetValue"], f"{FILES['condition']}: {r['targetId']}")
        for r in conditions
        if r.get("conditionId") in used
    }


def _experiments(
    tables: Mapping[str, Sequence[Mapping[str, str]]],
    outputs: Mapping[str, Mapping[str, Any]],
    output_of: Mapping[str, str],
) -> list[Experiment]:
    out = []
    for row in tables["experiment"]:
        eid = row["experimentId"]
        samples: dict[str, dict[float, float]] = {}
        for r in tables["measurement"]:
            if r["experimentId"] == eid:
                t = finite_number(r["time"], f"{FILES['measurement']}: {eid} time")
                output = output_of.get(r["observableId"])
                if output is None:
                    raise SpecError(
                        f"{FILES['measurement']}: {eid}: observable {r['observableId']!r} "
                        f"is not in {FILES['observable']}"
                    )
                samples.setdefault(output, {})[t] = finite_number(
                    r["measurement"], f"{FILES['measurement']}: {eid}"
                )
                if outputs[output]["sigma"] == "column":
                    samples.setdefault(f"sigma_{output}", {})[t] = finite_number(
                        r["noiseParameters"], f"{FILES['measurement']}: {eid} noiseParameters"
                    )
        for r in tables["input"]:
            if r["experimentId"] == eid:
                t = finite_number(r["time"], f"{FILES['input']}: {eid} time")
                samples.setdefault(r["inputId"], {})[t] = finite_number(
                    r["value"], f"{FILES['input']}: {eid}"
                )
        times = np.array(sorted({t for column in samples.values() for t in column}))
        columns = {
            name: np.array([column.get(t, np.nan) for t in times])
            for name, column in samples.items()
        }
        out.append(
            experiment_from_arrays(row.get("experimentName") or f"{eid}.csv", times, columns)
        )
    return out
