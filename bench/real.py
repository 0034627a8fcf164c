"""Real measured benchmarks end to end: the textbook model's test error before and after diagnosis.

For each benchmark of ``../shared/real`` (converted by ``examples/real/convert.py``), the
built-in textbook FMU is diagnosed on the estimation record with the official test records
held out, and a table is printed::

    benchmark | samples | test set | output | textbook RMS | after | published | effects | s

Usage::

    python bench/real.py [--real ../shared/real] [--silverbox train4000|train] [--only silverbox]
        [--workers N]

The published figures are those the benchmarks' MODEL.md files quote (Silverbox: the linear
model's free-run test error 7.07 mV on the multisine and 13.99 mV on the arrow, the Duffing
model's 0.96 and 1.00 mV). Timings are wall seconds on this machine; nothing is asserted.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "service"))

from fmuid.data import load_experiment, load_spec  # noqa: E402
from fmuid.discrepancy import diagnose  # noqa: E402
from fmuid.model.builtin import builtin_fmu  # noqa: E402

PUBLISHED = {
    ("silverbox", "silverbox_test_multisine.csv"): "7.07 -> 0.96 mV",
    ("silverbox", "silverbox_test_arrow.csv"): "13.99 -> 1.00 mV",
}
"""Linear model -> model with the cubic spring (free-run RMS, the benchmark's MODEL.md)."""

STUDIES = {
    "silverbox": (
        "msd",
        "silverbox_msd.json",
        ["silverbox_test_multisine.csv", "silverbox_test_arrow.csv"],
    ),
    "emps": ("emps", "emps.json", ["emps_test.csv"]),
}


def _converter() -> object:
    spec = importlib.util.spec_from_file_location("convert", ROOT / "examples/real/convert.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run(name: str, data: Path, estimation: str, out: Path, workers: int) -> list[list[str]]:
    """Diagnose one benchmark; return its table rows and write its result JSON into ``out``."""
    model, spec_file, tests = STUDIES[name]
    if estimation == "silverbox_train.csv":  # the whole training set starts from the 4,000's fit
        spec_file = "silverbox_msd_full.json"
    spec = load_spec(ROOT / "examples/real" / spec_file)
    train = load_experiment(data / estimation)
    held = [load_experiment(data / t) for t in tests]
    t0 = time.perf_counter()
    result = diagnose(builtin_fmu(model), [train], spec, test_data=held, workers=workers).to_dict()
    seconds = time.perf_counter() - t0
    (out / f"{name}.json").write_text(json.dumps(result, indent=1))
    named = ", ".join(e["label"] for e in result["effects"]) or str(result["effect"])
    rows = []
    for v in result["validation"]:
        rows.append(
            [
                name,
                str(len(train.time)),
                v["experiment"],
                v["output"],
                f"{v['rms_base']:.4g}",
                f"{v['rms_final']:.4g}",
                PUBLISHED.get((name, v["experiment"]), "-"),
                named,
                f"{seconds:.0f}",
            ]
        )
    return rows


def main() -> None:
    """Convert the records, diagnose each benchmark, print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real", type=Path, default=ROOT.parent / "shared" / "real")
    parser.add_argument("--silverbox", default="train4000", choices=["train4000", "train"])
    parser.add_argument("--only", choices=list(STUDIES))
    parser.add_argument(
        "--workers", type=int, default=os.cpu_count() or 1, help="diagnosis worker processes"
    )
    parser.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "fmuid-real")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    if not args.real.is_dir():
        sys.exit(f"no real recordings at {args.real}")
    data = args.out / "data"
    _converter().convert(args.real, data)  # type: ignore[attr-defined]
    estimation = {"silverbox": f"silverbox_{args.silverbox}.csv", "emps": "emps_estimation.csv"}
    rows = []
    for name in [args.only] if args.only else list(STUDIES):
        rows += run(name, data, estimation[name], args.out, args.workers)
    header = [
        "benchmark",
        "samples",
        "test set",
        "output",
        "textbook RMS",
        "after diagnosis",
        "published",
        "effects",
        "s",
    ]
    print("| " + " | ".join(header) + " |")  # noqa: T201
    print("|" + "---|" * len(header))  # noqa: T201
    for row in rows:
        print("| " + " | ".join(row) + " |")  # noqa: T201


if __name__ == "__main__":
    main()
