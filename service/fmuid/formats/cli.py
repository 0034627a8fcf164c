"""The ``fmuid`` commands that convert to and from standard files (SSV, PEtab)."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmuid.errors import DataError

if TYPE_CHECKING:
    from fmuid.data import Experiment


def add_commands(sub: Any) -> None:
    """Add ``export-ssv``, ``export-petab`` and ``import-petab`` to the ``fmuid`` parser."""
    p = sub.add_parser("export-ssv", help="write a fit or profile result as an SSP 2.0 SSV file")
    p.add_argument("--result", required=True, help="result JSON of fmuid fit or fmuid profile")
    p.add_argument("--fmu", required=True, help="the FMU (for its unit definitions)")
    p.add_argument("--out", required=True, help="the .ssv file to write")
    p.set_defaults(func=_export_ssv)

    p = sub.add_parser("export-petab", help="write a study as a PEtab-v2-style problem")
    p.add_argument("--fmu", required=True, help="FMU file or built-in model name")
    p.add_argument("--data", required=True, action="append", help="CSV file (repeatable)")
    p.add_argument("--spec", required=True, help="spec JSON")
    p.add_argument("--out", required=True, help="folder for problem.yaml, tables and the FMU")
    p.set_defaults(func=_export_petab)

    p = sub.add_parser("import-petab", help="turn a PEtab problem into a spec and CSV files")
    p.add_argument("--problem", required=True, help="the problem.yaml")
    p.add_argument("--out", required=True, help="folder for spec.json and one CSV per experiment")
    p.set_defaults(func=_import_petab)


def _export_ssv(args: argparse.Namespace) -> int:
    from fmuid.formats.ssv import fmu_unit_definitions, write_ssv
    from fmuid.model.builtin import resolve_fmu

    try:
        result = json.loads(Path(args.result).read_text())
    except (OSError, ValueError) as exc:
        raise DataError(f"{args.result}: not a readable result JSON: {exc}") from exc
    if not isinstance(result, dict) or not isinstance(result.get("parameters"), dict):
        raise DataError(f"{args.result}: not a fit or profile result (no 'parameters')")
    units = fmu_unit_definitions(resolve_fmu(args.fmu))
    print(write_ssv(result, args.out, unit_definitions=units))  # noqa: T201
    return 0


def _export_petab(args: argparse.Namespace) -> int:
    from fmuid.data import load_experiment, load_spec
    from fmuid.formats.petab import write_petab
    from fmuid.model.builtin import resolve_fmu

    experiments = [load_experiment(p) for p in args.data]
    path = write_petab(args.out, resolve_fmu(args.fmu), experiments, load_spec(args.spec))
    print(path)  # noqa: T201
    return 0


def _import_petab(args: argparse.Namespace) -> int:
    from fmuid.formats.petab_read import read_petab

    problem = read_petab(args.problem)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    spec_path = out / "spec.json"
    spec_path.write_text(problem.spec.model_dump_json(indent=2, exclude_none=True) + "\n")
    data = [write_csv(e, out / Path(e.name).name) for e in problem.experiments]
    flags = " ".join(f"--data {p}" for p in data)
    print(f"fmuid fit --fmu {problem.fmu} {flags} --spec {spec_path} --out result.json")  # noqa: T201
    return 0


def write_csv(experiment: Experiment, path: Path) -> Path:
    """Write an experiment as fmuid's CSV (empty cells where a column has no sample)."""
    names = list(experiment.columns)
    lines = [",".join(["time", *names])]
    for i, t in enumerate(experiment.time):
        cells = [_cell(experiment.columns[n][i]) for n in names]
        lines.append(",".join([repr(float(t)), *cells]))
    path.write_text("\n".join(lines) + "\n")
    return path


def _cell(value: float) -> str:
    return "" if math.isnan(value) else repr(float(value))
