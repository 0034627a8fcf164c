"""Confusion table of ``fmuid.diagnose`` on independent field-truth cases.

Every catalogue effect at two magnitudes and several seeds, no-effect controls and one effect
that is not in the catalogue (hitch stiffness), each a 20 s step steer and a 30 s chirp made by
``tests/fieldtruth.py`` (scipy, independent of the FMU and of the candidate wrappers).

    python bench/diagnose.py [--seeds 2] [--controls 4] [--effects sensor_lag,...] [--log F]

Prints one line per case as it finishes, then the table: rows are the true effects, columns
the named effects; and per effect how often it was flagged, named right, and how often the
added parameter's interval contains the true magnitude.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "service"))

import fieldtruth as ft  # noqa: E402
from fmuid.data import spec_from_json  # noqa: E402
from fmuid.diagnose import diagnose  # noqa: E402
from fmuid.model.builtin import builtin_fmu  # noqa: E402

PARAMETER = {
    "sensor_lag": "tau_sensor",
    "input_delay": "delay_delta",
    "steering_lag": "tau_steer",
    "steer_offset": "offset_steer",
    "tire_saturation": "alpha_sat",
    "side_slope": "slope",
}
CATALOGUE = [e for e in ft.EFFECTS if e != "hitch_stiffness"]


def study_spec() -> object:
    """The six tire parameters free (thesis Table 3.2), sigma from the columns, local fit."""
    return spec_from_json(
        json.dumps(
            {
                "parameters": {
                    n: {"start": ft.NOMINAL[n], "lower": lo, "upper": hi}
                    for n, (lo, hi) in ft.BOUNDS.items()
                },
                "inputs": ["delta"],
                "outputs": {"gam_t": {"sigma": "column"}, "gam_i": {"sigma": "column"}},
                "global_search": False,
            }
        )
    )


def effect_chi2(case: ft.Case) -> float:
    """Chi2 the effect alone adds at the true parameters: how observable it is at best."""
    if case.effect is None:
        return 0.0
    total = 0.0
    for exp in case.experiments:
        t_in, u_in = exp.input_samples("delta")
        mask = exp.output_mask("gam_t")
        t = exp.time[mask]
        base = ft.simulate_truth(case.truth, t_in, u_in, t)
        with_effect = dict(base)
        if case.effect == "gyro_bias":
            with_effect[case.bias_output] = base[case.bias_output] + case.magnitude
        else:
            with_effect = ft.simulate_truth(case.truth, t_in, u_in, t, case.effect, case.magnitude)
        for output in ("gam_t", "gam_i"):
            d = (with_effect[output] - base[output]) / exp.columns[f"sigma_{output}"][mask]
            total += float(d @ d)
    return total


def run_case(effect: str | None, level: int, seed: int) -> dict[str, object]:
    """Diagnose one case and return what the table needs."""
    magnitude = ft.MAGNITUDES[effect][level] if effect else 0.0
    case = ft.make_case(effect, magnitude, seed=seed)
    t0 = time.perf_counter()
    d = diagnose(builtin_fmu("tractor_implement"), case.experiments, study_spec()).to_dict()
    name = PARAMETER.get(effect or "", f"bias_{case.bias_output}")
    if effect in d["indistinguishable"] and d["effect"] in PARAMETER:
        name = PARAMETER[d["effect"]]  # an equivalent model names the same magnitude
    added = d["added_parameters"].get(name)
    contains = None
    if added is not None and effect in CATALOGUE:
        lo, hi = added["ci"]
        contains = (lo is None or lo <= case.magnitude) and (hi is None or case.magnitude <= hi)
    return {
        "effect": effect or "control",
        "level": level,
        "seed": seed,
        "truth": case.magnitude,
        "named": d["effect"] if d["mismatch"] else "none",
        "second": d["second_effect"],
        "ties": d["indistinguishable"],
        "estimate": None if added is None else added["estimate"],
        "ci": None if added is None else added["ci"],
        "contains": contains,
        "chi2": [round(d["chi2_before"], 1), round(d["chi2_after"], 1)],
        "n_data": d["n_data"],
        "effect_chi2": round(effect_chi2(case), 1),
        "seconds": round(time.perf_counter() - t0, 1),
    }


def main() -> None:
    """Run the cases and print the table."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--controls", type=int, default=4)
    parser.add_argument("--table", type=Path, default=None, help="print the table of a log")
    parser.add_argument("--effects", default=",".join(ft.EFFECTS))
    parser.add_argument("--log", type=Path, default=None, help="append JSON lines here")
    args = parser.parse_args()
    if args.table:
        print_table([json.loads(line) for line in args.table.read_text().splitlines()])
        return
    s0 = args.first_seed
    cases: list[tuple[str | None, int, int]]
    cases = [(None, 0, 100 + s0 + s) for s in range(args.controls)]
    for effect in args.effects.split(","):
        cases += [(effect, lv, s) for lv in (0, 1) for s in range(s0, s0 + args.seeds)]
    rows = []
    for effect, level, seed in cases:
        row = run_case(effect, level, seed)
        rows.append(row)
        print(json.dumps(row), flush=True)
        if args.log:
            with args.log.open("a") as f:
                f.write(json.dumps(row) + "\n")
    print_table(rows)


def print_table(rows: list[dict[str, object]]) -> None:
    """Print the confusion table and the per-effect rates."""
    truths = list(dict.fromkeys(str(r["effect"]) for r in rows))
    named = ["none", *CATALOGUE, "unexplained"]
    counts: dict[str, Counter[str]] = defaultdict(Counter)
    for r in rows:
        counts[str(r["effect"])][str(r["named"])] += 1
    short = {n: n[:9] for n in named}
    print()
    print("true \\ named".ljust(16) + "".join(short[n].rjust(10) for n in named) + "    n")
    for t in truths:
        line = t.ljust(16) + "".join(str(counts[t][n] or ".").rjust(10) for n in named)
        print(line + str(sum(counts[t].values())).rjust(5))
    print()
    print("effect".ljust(16) + "flagged  named-right  tie-aware  ci-contains-truth")
    for t in truths:
        rs = [r for r in rows if r["effect"] == t]
        right = "unexplained" if t == "hitch_stiffness" else ("none" if t == "control" else t)
        flagged = sum(r["named"] != "none" for r in rs)
        ok = sum(r["named"] == right for r in rs)
        tie = sum(r["named"] == right or right in r["ties"] for r in rs)  # type: ignore[operator]
        ci = [r["contains"] for r in rs if r["contains"] is not None]
        print(
            t.ljust(16)
            + f"{flagged}/{len(rs)}".rjust(7)
            + f"{ok}/{len(rs)}".rjust(13)
            + f"{tie}/{len(rs)}".rjust(11)
            + (f"{sum(ci)}/{len(ci)}".rjust(19) if ci else "-".rjust(19))
        )
    seconds = [float(r["seconds"]) for r in rows]  # type: ignore[arg-type]
    hidden = [r for r in rows if r["named"] == "none" and r["effect"] != "control"]
    for r in hidden:
        print(
            f"missed: {r['effect']} level {r['level']} seed {r['seed']}: the effect alone adds "
            f"chi2 {r.get('effect_chi2', '?')} over {r['n_data']} data at the true parameters"
        )
    print(f"\n{len(rows)} cases, median {sorted(seconds)[len(seconds) // 2]:.0f} s per diagnosis")


if __name__ == "__main__":
    main()
