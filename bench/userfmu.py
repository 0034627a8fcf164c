"""``fmuid.diagnose`` on concealed effects in a user's FMU (a pythonfmu DC motor), against controls.

Cases come from ``testbed/usermotor.py``: the motor's truth solved by scipy with one effect on
the voltage or on a measured output (delay, lag, offset, gain, saturation; bias, gain, lag,
saturation), its magnitude sized per case so that the base fit (R, J, b free) leaves residuals
that pass Ljung-Box and the chi2 noise band while the true augmentation's likelihood ratio has
p in [1e-12, 1e-3]. The FMU is built here by pythonfmu; only the diagnose result JSON is read.

    python bench/userfmu.py [--seeds 2] [--controls 6] [--effects input_delay,...]
        [--cache DIR] [--jobs N] [--log F] [--no-absorbed] [--skip-done LOG]
    python bench/userfmu.py --table F [F ...]

Prints one JSON line per case, then per effect: cases, flagged, named right, named right or
tied (the truth in ``indistinguishable``), and the controls' false alarms; median seconds and
simulations per diagnosis.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "testbed"))
sys.path.insert(0, str(ROOT / "service"))

import usermotor as um  # noqa: E402
from fmuid.data import spec_from_json  # noqa: E402
from fmuid.discrepancy import DiagnoseOptions, diagnose  # noqa: E402


def run_case(
    task: tuple[str | None, int], cache: Path | None, fmu_dir: Path, absorbed: bool
) -> dict[str, Any]:
    """Make (or load) one case and diagnose it; an engine failure becomes a row."""
    effect, seed = task
    row: dict[str, Any] = {"effect": effect or "control", "seed": seed}
    case = um.get_case(effect, seed, cache)
    row.update(magnitude=case.magnitude, channel=case.channel)
    row.update({k: case.info.get(k) for k in ("concealed", "lrt_p", "achieved_lambda")})
    t0 = time.perf_counter()
    try:
        spec = spec_from_json(um.study_spec_json())
        options = DiagnoseOptions(absorbed=absorbed)
        result = diagnose(um.build_fmu(fmu_dir), case.experiments, spec, options=options).to_dict()
    except Exception as exc:  # a failure is a result of the bench, not its end
        return {**row, "error": f"{type(exc).__name__}: {exc}"}
    row["seconds"] = round(time.perf_counter() - t0, 1)
    ties = [
        t["effect"] if isinstance(t, dict) else str(t)
        for t in result.get("indistinguishable") or []
    ]
    steps = result.get("effects") or []
    row.update(
        mismatch=result["mismatch"],
        named=result["effect"] if result["mismatch"] else "none",
        ties=ties,
        steps=[s.get("effect") for s in steps],
        added={s.get("effect"): s.get("parameters") for s in steps},
        chi2_before=round(result["chi2_before"], 1),
        chi2_after=round(result["chi2_after"], 1),
        simulations=(result.get("cost") or {}).get("simulations"),
    )
    return row


def table(rows: list[dict[str, Any]]) -> None:
    """Per effect: flagged, named right, named right or tied; controls: false alarms."""
    print(
        f"\n{'effect':<18} {'cases':>5} {'concealed':>9} {'flagged':>7} {'named':>5} "
        f"{'or tied':>7} {'median s':>8}"
    )
    for effect in ["control", *um.EFFECTS]:
        sel = [r for r in rows if r["effect"] == effect and "mismatch" in r]
        if not sel:
            continue
        secs = statistics.median(r["seconds"] for r in sel)
        flagged = sum(r["mismatch"] for r in sel)
        if effect == "control":
            print(
                f"{'control':<18} {len(sel):>5} {'':>9} {flagged:>7} {'':>5} {'':>7} {secs:>8.0f}"
                "   (flagged = false alarms)"
            )
            continue
        named = sum(r["named"] == effect for r in sel)
        tied = sum(r["named"] == effect or effect in r["ties"] for r in sel)
        conc = sum(bool(r.get("concealed")) for r in sel)
        print(
            f"{effect:<18} {len(sel):>5} {conc:>9} {flagged:>7} {named:>5} {tied:>7} {secs:>8.0f}"
        )
    for r in rows:
        if "error" in r:
            print(f"FAILED: {r['effect']} seed {r['seed']}: {r['error']}")


def main() -> None:
    """Run the cases and print the table."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--seeds", type=int, default=2, help="concealed cases per effect")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--controls", type=int, default=6)
    parser.add_argument("--effects", default=",".join(um.EFFECTS))
    parser.add_argument("--cache", type=Path, default=None, help="folder of generated cases")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes")
    parser.add_argument("--log", type=Path, default=None, help="append JSON lines here")
    parser.add_argument("--table", type=Path, nargs="+", help="print the table of logs")
    parser.add_argument(
        "--no-absorbed",
        action="store_true",
        help="skip the re-profiles of the original parameters (they do not enter the table)",
    )
    parser.add_argument(
        "--skip-done", type=Path, default=None, help="skip the cases already diagnosed in this log"
    )
    args = parser.parse_args()
    if args.table:
        table([json.loads(line) for f in args.table for line in f.read_text().splitlines()])
        return
    unknown = set(args.effects.split(",")) - set(um.EFFECTS)
    if unknown:
        parser.error(f"--effects: unknown {sorted(unknown)}; known: {', '.join(um.EFFECTS)}")
    s0 = args.first_seed
    tasks: list[tuple[str | None, int]] = [(None, s0 + s) for s in range(args.controls)]
    tasks += [(e, s0 + s) for s in range(args.seeds) for e in args.effects.split(",")]
    if args.skip_done and args.skip_done.exists():
        rows_done = [json.loads(line) for line in args.skip_done.read_text().splitlines()]
        done = {(r["effect"], r["seed"]) for r in rows_done if "mismatch" in r}
        tasks = [t for t in tasks if (t[0] or "control", t[1]) not in done]
    fmu_dir = Path(tempfile.mkdtemp(prefix="fmuid-userfmu-"))
    um.build_fmu(fmu_dir)
    rows = []
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        n = len(tasks)
        absorbed = [not args.no_absorbed] * n
        for row in pool.map(run_case, tasks, [args.cache] * n, [fmu_dir] * n, absorbed):
            rows.append(row)
            print(json.dumps(row), flush=True)
            if args.log:
                with args.log.open("a") as f:
                    f.write(json.dumps(row) + "\n")
    table(rows)


if __name__ == "__main__":
    main()
