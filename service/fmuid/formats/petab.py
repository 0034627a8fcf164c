"""A PEtab-v2-style problem whose model is an FMU, plus a table of measured input trajectories.

``problem.yaml`` (format 2.0.0) names the FMU as its model (``language: fmu``), the parameter,
observable, measurement, condition and experiment tables, and the ``fmuid`` extension: the
``inputs.tsv`` table (measured input samples such as the steer angle, linear between samples)
and the study options PEtab has no column for. See docs/formats.md for the mapping.
"""

from __future__ import annotations

import csv
import logging
import os
import re
import shutil
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from fmuid.data import Experiment, Spec
from fmuid.model.fmu import FmuModel

logger = logging.getLogger(__name__)

FORMAT_VERSION = "2.0.0"
EXTENSION_VERSION = "1.0.0"
FILES = {
    "parameter": "parameters.tsv",
    "observable": "observables.tsv",
    "measurement": "measurements.tsv",
    "condition": "conditions.tsv",
    "experiment": "experiments.tsv",
    "input": "inputs.tsv",
}
PLACEHOLDER = "noiseParameter1_{}"
FIXED_CONDITION = "fmuid_fixed"


@dataclass(frozen=True)
class PetabProblem:
    """A problem read from PEtab files: what ``fmuid.fit`` and ``fmuid.profile`` take.

    Attributes
    ----------
    fmu
        The FMU file named by ``model_files``.
    experiments
        One experiment per PEtab experiment, inputs and measured outputs merged on time.
    spec
        Free parameters, fixed values, outputs with their noise, and the study options.

    """

    fmu: Path
    experiments: list[Experiment]
    spec: Spec


def write_petab(
    directory: str | os.PathLike[str],
    fmu: str | os.PathLike[str],
    experiments: Sequence[Experiment],
    spec: Spec,
) -> Path:
    """Write a study as a PEtab-v2-style problem with the FMU copied beside it.

    Parameters
    ----------
    directory
        Output folder (created); it receives ``problem.yaml``, the tables and the FMU.
    fmu
        The FMU file.
    experiments
        The data.
    spec
        The study.

    Returns
    -------
    Path
        The ``problem.yaml`` written.

    Raises
    ------
    SpecError
        If the spec uses something PEtab cannot carry (switchable physics is left out with a
        warning instead).

    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    if spec.physics:
        logger.warning("PEtab has no switchable physics: spec.physics is not exported")
    if spec.per_experiment:
        logger.warning(
            "spec.per_experiment is not exported: %s become one parameter shared by every "
            "experiment",
            ", ".join(spec.per_experiment),
        )
    ids = _experiment_ids([e.name for e in experiments])
    model_file = Path(fmu).name
    shutil.copyfile(fmu, out / model_file)
    model = FmuModel(Path(fmu))
    obs_ids = observable_ids(spec.outputs, {*model.parameters, *model.inputs, *model.outputs})
    noise = [_observable(output, obs_ids[output], o.sigma) for output, o in spec.outputs.items()]
    params = [
        {
            "parameterId": name,
            "parameterScale": "log10" if p.resolved_scale == "log" else "lin",
            "lowerBound": _num(p.lower),
            "upperBound": _num(p.upper),
            "nominalValue": _num(p.start),
            "estimate": "true",
        }
        for name, p in spec.parameters.items()
    ]
    for output, o in spec.outputs.items():
        if o.sigma == "estimate":
            scale = _data_scale(experiments, output)
            params.append(
                {
                    "parameterId": f"sigma_{output}",
                    "parameterScale": "log10",
                    "lowerBound": _num(scale * 1e-6),
                    "upperBound": _num(scale * 10),
                    "nominalValue": _num(scale),
                    "estimate": "true",
                }
            )
    numeric = {k: v for k, v in spec.fixed.items() if not isinstance(v, str)}
    text = {k: v for k, v in spec.fixed.items() if isinstance(v, str)}
    conditions = [
        {"conditionId": FIXED_CONDITION, "targetId": k, "targetValue": _num(float(v))}
        for k, v in numeric.items()
    ]
    condition = FIXED_CONDITION if conditions else ""
    _write_tsv(out / FILES["parameter"], params, _PARAMETER_COLUMNS)
    _write_tsv(out / FILES["observable"], noise, _OBSERVABLE_COLUMNS)
    _write_tsv(out / FILES["condition"], conditions, ("conditionId", "targetId", "targetValue"))
    _write_tsv(
        out / FILES["experiment"],
        [
            {
                "experimentId": i,
                "time": _num(e.time[0]),
                "conditionId": condition,
                "experimentName": e.name,
            }
            for i, e in zip(ids, experiments, strict=True)
        ],
        ("experimentId", "time", "conditionId", "experimentName"),
    )
    _write_tsv(
        out / FILES["measurement"],
        _measurements(ids, obs_ids, experiments, spec),
        ("observableId", "experimentId", "time", "measurement", "noiseParameters"),
    )
    _write_tsv(
        out / FILES["input"],
        _input_rows(ids, experiments, spec, model.inputs),
        ("experimentId", "time", "inputId", "value"),
    )
    problem = {
        "format_version": FORMAT_VERSION,
        "model_files": {_model_id(model_file): {"location": model_file, "language": "fmu"}},
        "parameter_files": [FILES["parameter"]],
        "observable_files": [FILES["observable"]],
        "measurement_files": [FILES["measurement"]],
        "condition_files": [FILES["condition"]],
        "experiment_files": [FILES["experiment"]],
        "extensions": {
            "fmuid": {
                "version": EXTENSION_VERSION,
                "required": True,
                "input_files": [FILES["input"]],
                "inputs": list(spec.inputs),
                "confidence": spec.confidence,
                "global_search": spec.global_search,
                "seed": spec.seed,
                "interface": spec.interface,
                "fixed_text": text,
            }
        },
    }
    path = out / "problem.yaml"
    path.write_text(yaml.safe_dump(problem, sort_keys=False))
    return path


_PARAMETER_COLUMNS = (
    "parameterId",
    "parameterScale",
    "lowerBound",
    "upperBound",
    "nominalValue",
    "estimate",
)
_OBSERVABLE_COLUMNS = (
    "observableId",
    "observableFormula",
    "noiseFormula",
    "noisePlaceholders",
    "noiseDistribution",
)


def observable_ids(outputs: Iterable[str], model_names: Iterable[str]) -> dict[str, str]:
    """Return the PEtab observable id of each output: ``obs_<output>``.

    PEtab forbids an observable id that names a model entity, so the id is never the output's
    own name; a clash with another FMU variable gets a number appended.
    """
    taken = set(model_names)
    ids = {}
    for output in outputs:
        ids[output] = _unique(f"obs_{output}", taken)
        taken.add(ids[output])
    return ids


def _observable(output: str, oid: str, sigma: float | str) -> dict[str, Any]:
    formula = {"column": PLACEHOLDER.format(oid), "estimate": f"sigma_{output}"}
    return {
        "observableId": oid,
        "observableFormula": output,
        "noiseFormula": formula[sigma] if isinstance(sigma, str) else _num(sigma),
        "noisePlaceholders": PLACEHOLDER.format(oid) if sigma == "column" else "",
        "noiseDistribution": "normal",
    }


def _unique(base: str, taken: set[str]) -> str:
    candidate, k = base, 1
    while candidate in taken:
        k += 1
        candidate = f"{base}_{k}"
    return candidate


def _experiment_ids(names: Iterable[str]) -> list[str]:
    ids: list[str] = []
    for name in names:
        base = re.sub(r"\W", "_", Path(name).stem) or "experiment"
        ids.append(_unique(base if re.match(r"[A-Za-z_]", base) else f"e_{base}", set(ids)))
    return ids


def _model_id(file_name: str) -> str:
    base = re.sub(r"\W", "_", Path(file_name).stem)
    return base if re.match(r"[A-Za-z_]", base) else f"m_{base}"


def _data_scale(experiments: Sequence[Experiment], output: str) -> float:
    values = np.concatenate([e.output_values(output) for e in experiments])
    spread = float(np.std(values)) if values.size > 1 else 0.0
    return spread if spread > 0 else 1.0


def _measurements(
    ids: Sequence[str],
    obs_ids: Mapping[str, str],
    experiments: Sequence[Experiment],
    spec: Spec,
) -> list[dict[str, Any]]:
    rows = []
    for eid, exp in zip(ids, experiments, strict=True):
        for output, o in spec.outputs.items():
            mask = exp.output_mask(output)
            sigma = exp.sigma_column(output) if o.sigma == "column" else None
            for i in np.flatnonzero(mask):
                rows.append(
                    {
                        "observableId": obs_ids[output],
                        "experimentId": eid,
                        "time": _num(exp.time[i]),
                        "measurement": _num(exp.columns[output][i]),
                        "noiseParameters": "" if sigma is None else _num(sigma[i]),
                    }
                )
    return rows


def _input_rows(
    ids: Sequence[str], experiments: Sequence[Experiment], spec: Spec, fmu_inputs: Iterable[str]
) -> list[dict[str, Any]]:
    wanted = set(spec.inputs or fmu_inputs)
    rows = []
    for eid, exp in zip(ids, experiments, strict=True):
        for name in [c for c in exp.columns if c in wanted]:
            t, v = exp.input_samples(name)
            rows += [
                {"experimentId": eid, "time": _num(ti), "inputId": name, "value": _num(vi)}
                for ti, vi in zip(t, v, strict=True)
            ]
    return rows


def _num(value: float) -> str:
    return repr(float(value))


def _write_tsv(path: Path, rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, columns, delimiter="\t", lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
