"""Confusion table of ``fmuid.diagnose`` on concealed, independent field-truth cases.

Cases come from ``testbed/concealed.py`` (the field truth of ``testbed/fieldtruth.py``, scipy,
independent of the FMU and of the diagnose engine): per effect, its magnitude is set per case so
that the base fit hides it from the residuals (Ljung-Box at 5 % passes on every channel, the
reduced chi2 is noise-sized) while the likelihood-ratio test of the true augmentation has
p in [1e-12, 1e-3]. Controls are drawn the same way without an effect. Only the result JSON of
``diagnose`` is read.

    python bench/diagnose.py [--seeds 8] [--controls 30] [--effects output_lag,...]
        [--cache DIR] [--jobs N] [--workers W] [--shard K/N] [--log F] [--generate-only]
        [--easy [--easy-seeds 2]] [--no-absorbed] [--skip-done LOG]
    python bench/diagnose.py --false-alarm 200 [--cache DIR] [--jobs N] [--shard K/N] [--log F]
    python bench/diagnose.py --table F [F ...]      # the tables of logged runs (merged shards)

Prints one JSON line per case as it finishes, then the confusion table of the concealed cases
(and apart from it, with ``--easy``, of today's fixed "easy" magnitudes), per effect how often
it was flagged, named right, named right or tied with the truth listed, and how often the added
parameter's 95 % interval contains the true magnitude (over all cases of the effect), and the
median seconds per diagnosis (each with ``--workers`` processes for its profiles, by default
the machine's cores shared among the ``--jobs``, as ``fmuid diagnose`` uses them).
``--false-alarm N`` diagnoses N controls and prints the false-alarm rate with its
Clopper-Pearson 95 % interval.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "testbed"))
sys.path.insert(0, str(ROOT / "service"))

import concealed as cc  # noqa: E402
import fieldtruth as ft  # noqa: E402
from diagnose_tables import CATALOGUE, print_false_alarm, print_tables  # noqa: E402
from fmuid.discrepancy import DiagnoseOptions, diagnose  # noqa: E402
from fmuid.model.builtin import builtin_fmu  # noqa: E402
from operational import study_spec  # noqa: E402

PARAMETER = {
    "output_lag": "tau_outputs",
    "input_delay": "delay_delta",
    "input_lag": "tau_delta",
    "input_offset": "offset_delta",
    "tire_saturation": "alpha_sat",
    "side_slope": "slope",
}
"""Added parameter of each effect (``output_bias``: ``bias_<output>``)."""
FALSE_ALARM_SEED = 10_000
"""First seed of the false-alarm controls (apart from the 30 controls of the table)."""

Task = tuple[str, str | None, int, int]
"""(kind, effect, seed, level): kind ``concealed``, ``control``, ``easy`` or ``false_alarm``."""


def tasks(args: argparse.Namespace) -> list[Task]:
    """Every case of the run, in a fixed order (so that shards are stable)."""
    if args.false_alarm:
        return [("false_alarm", None, FALSE_ALARM_SEED + i, 0) for i in range(args.false_alarm)]
    s0 = args.first_seed
    out: list[Task] = [("control", None, s0 + s, 0) for s in range(args.controls)]
    effects = args.effects.split(",")
    out += [("concealed", e, s0 + s, 0) for s in range(args.seeds) for e in effects]
    easy = range(s0, s0 + args.easy_seeds if args.easy else s0)
    out += [("easy", e, s, lv) for e in effects for lv in (0, 1) for s in easy]
    return out


def tie_names(ties: Any) -> list[str]:
    """Effect names of ``indistinguishable``: plain names or ``{"effect": ...}`` objects."""
    return [t["effect"] if isinstance(t, dict) else str(t) for t in ties or []]


def read_result(d: dict[str, Any], effect: str | None, case: ft.Case) -> dict[str, Any]:
    """What the table needs from a diagnose result JSON."""
    named = d["effect"] if d["mismatch"] else "none"
    ties = tie_names(d.get("indistinguishable"))
    name = PARAMETER.get(effect or "", f"bias_{case.bias_output}")
    added = (d.get("added_parameters") or {}).get(name)
    for tie in d.get("indistinguishable") or []:
        intervals = tie.get("intervals", {}) if isinstance(tie, dict) else {}
        if intervals and tie["effect"] == effect and name in intervals:
            added = intervals[name]  # the truth listed as equally good, with its interval
    contains = None
    if effect in CATALOGUE:
        contains = False
        if added is not None:
            lo, hi = added["ci"]
            contains = (lo is None or lo <= case.magnitude) and (hi is None or case.magnitude <= hi)
    return {
        "named": named,
        "ties": ties,
        "estimate": None if added is None else added["estimate"],
        "ci": None if added is None else added["ci"],
        "contains": contains,
        "chi2_before": round(float(d["chi2_before"]), 1),
        "n_data": d["n_data"],
    }


def make_case(task: Task, cache: Path | None) -> tuple[ft.Case, dict[str, Any]]:
    """Generate (or load) the case of a task; return it and what was checked about it."""
    kind, effect, seed, level = task
    if kind == "easy":
        assert effect is not None
        return ft.make_case(effect, ft.MAGNITUDES[effect][level], seed=seed), {}
    made = cc.get_case(effect if kind == "concealed" else None, seed, cache)
    info: dict[str, Any] = {}
    if kind == "concealed":
        check = made.check
        info = {
            "concealed": made.concealed,
            "target_lambda": round(made.target_lambda, 1),
            "lambda": round(made.achieved_lambda, 1),
            "lrt_p": check.get("lrt_p"),
            "reduced_chi2": round(float(check["reduced_chi2"]), 3),
            "min_ljung_box_p": round(min(check["ljung_box"].values()), 3),
            "attempts": made.attempts,
            "failures": check["failures"],
        }
    return made.case, info


def run_task(
    task: Task, cache: Path | None, generate_only: bool, options: DiagnoseOptions
) -> dict[str, Any]:
    """Generate one case and (unless ``generate_only``) diagnose it; failures become a row."""
    kind, effect, seed, level = task
    row: dict[str, Any] = {"kind": kind, "effect": effect or "control", "seed": seed}
    row["level"] = level
    t0 = time.perf_counter()
    try:
        case, info = make_case(task, cache)
    except Exception as exc:  # a bench reports a case it cannot make and goes on
        return {**row, "error": f"generation: {type(exc).__name__}: {exc}"}
    row.update(truth=case.magnitude, **info)
    row["generate_seconds"] = round(time.perf_counter() - t0, 1)
    if generate_only:
        return row
    t0 = time.perf_counter()
    try:
        fmu = builtin_fmu("tractor_implement")
        result = diagnose(fmu, case.experiments, study_spec(), options=options).to_dict()
    except Exception as exc:  # an engine failure is a result of the bench, not its end
        return {**row, "error": f"diagnose: {type(exc).__name__}: {exc}"}
    row.update(read_result(result, effect, case))
    row["seconds"] = round(time.perf_counter() - t0, 1)
    return row


def run(selected: list[Task], args: argparse.Namespace) -> Iterator[dict[str, Any]]:
    """Run the tasks, in this process or in ``args.jobs`` worker processes."""
    workers = args.workers or max(1, (os.cpu_count() or 1) // max(1, args.jobs))
    options = DiagnoseOptions(absorbed=not args.no_absorbed, workers=workers)
    if args.jobs <= 1:
        for task in selected:
            yield run_task(task, args.cache, args.generate_only, options)
        return
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = [
            pool.submit(run_task, t, args.cache, args.generate_only, options) for t in selected
        ]
        for future in as_completed(futures):
            yield future.result()


def main() -> None:
    """Run the cases and print the tables."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--seeds", type=int, default=8, help="concealed cases per effect")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--controls", type=int, default=30)
    parser.add_argument("--effects", default=",".join(ft.EFFECTS))
    parser.add_argument("--easy", action="store_true", help="also today's fixed magnitudes")
    parser.add_argument("--easy-seeds", type=int, default=2, help="easy cases per magnitude")
    parser.add_argument("--false-alarm", type=int, default=0, metavar="N", help="N controls only")
    parser.add_argument("--cache", type=Path, default=None, help="folder of generated cases")
    parser.add_argument("--jobs", type=int, default=1, help="cases diagnosed side by side")
    parser.add_argument(
        "--workers", type=int, default=None, help="profile processes per diagnosis (cores / jobs)"
    )
    parser.add_argument("--shard", default="0/1", help="K/N: run every N-th case from the K-th")
    parser.add_argument("--generate-only", action="store_true", help="fill the cache only")
    parser.add_argument("--log", type=Path, default=None, help="append JSON lines here")
    parser.add_argument("--table", type=Path, nargs="+", help="print the tables of logs")
    parser.add_argument(
        "--no-absorbed",
        action="store_true",
        help="skip the re-profiles of the original parameters (they do not enter the tables)",
    )
    parser.add_argument(
        "--skip-done", type=Path, default=None, help="skip the cases already diagnosed in this log"
    )
    args = parser.parse_args()
    if args.table:
        rows = [json.loads(line) for f in args.table for line in f.read_text().splitlines()]
        report(rows)
        return
    unknown = set(args.effects.split(",")) - set(ft.EFFECTS)
    if unknown:
        parser.error(f"--effects: unknown {sorted(unknown)}; known: {', '.join(ft.EFFECTS)}")
    k, n = (int(x) for x in args.shard.split("/"))
    if not 0 <= k < n:
        parser.error(f"--shard {args.shard}: need 0 <= K < N")
    selected = tasks(args)[k::n]
    if args.skip_done and args.skip_done.exists():
        rows_done = [json.loads(line) for line in args.skip_done.read_text().splitlines()]
        done = {(r["kind"], r["seed"], r["level"], r["effect"]) for r in rows_done if "named" in r}
        selected = [t for t in selected if (t[0], t[2], t[3], t[1] or "control") not in done]
    rows = []
    for row in run(selected, args):
        rows.append(row)
        print(json.dumps(row), flush=True)
        if args.log:
            with args.log.open("a") as f:
                f.write(json.dumps(row) + "\n")
    if not args.generate_only:
        report(rows)


def report(rows: list[dict[str, Any]]) -> None:
    """Print the false-alarm summary and the confusion tables present in ``rows``."""
    for r in rows:
        if "error" in r:
            print(f"FAILED: {r['kind']} {r['effect']} seed {r['seed']}: {r['error']}")
    print_false_alarm([r for r in rows if r["kind"] == "false_alarm" and "named" in r])
    print_tables([r for r in rows if r["kind"] != "false_alarm" and "named" in r])


if __name__ == "__main__":
    main()
