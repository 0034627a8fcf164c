"""Tables of ``bench/diagnose.py``: confusion, per-effect rates, false alarms."""

from __future__ import annotations

import statistics
from collections import Counter, defaultdict
from typing import Any

from scipy import stats

import fieldtruth as ft

CATALOGUE = [e for e in ft.EFFECTS if e not in ft.UNCATALOGUED]


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Exact binomial interval of a rate ``k / n``."""
    tail = (1.0 - level) / 2
    lo = float(stats.beta.ppf(tail, k, n - k + 1)) if k > 0 else 0.0
    hi = float(stats.beta.isf(tail, k + 1, n - k)) if k < n else 1.0
    return lo, hi


def print_false_alarm(rows: list[dict[str, Any]]) -> None:
    """False alarms among control data sets, with the exact 95 % interval of the rate."""
    if not rows:
        return
    n = len(rows)
    k = sum(r["named"] != "none" for r in rows)
    lo, hi = clopper_pearson(k, n)
    print(
        f"\nfalse alarms: {k} of {n} controls, rate {k / n:.3%} "
        f"(Clopper-Pearson 95 %: {lo:.3%} .. {hi:.3%}); "
        f"median {median(rows, 'seconds'):.0f} s per diagnosis"
    )
    for r in rows:
        if r["named"] != "none":
            print(f"  false alarm: seed {r['seed']} named {r['named']}")


def print_tables(rows: list[dict[str, Any]]) -> None:
    """Confusion tables of the concealed cases (with controls) and, apart, of the easy ones."""
    concealed = [r for r in rows if r["kind"] == "control" or r.get("concealed")]
    visible = [r for r in rows if r["kind"] == "concealed" and not r.get("concealed")]
    easy = [r for r in rows if r["kind"] == "easy"]
    if concealed:
        print("\nCONCEALED cases (the base fit hides the effect) and controls")
        confusion(concealed)
        summary(concealed)
    for r in concealed:
        if r["named"] == "none" and r["effect"] != "control":
            print(
                f"missed: {r['effect']} seed {r['seed']} (magnitude {r['truth']:.4g}): noise-free "
                f"lambda {r['lambda']}, LRT p of the true augmentation {r['lrt_p']}"
            )
    for r in visible:
        print(
            f"not concealed (kept out of the table): {r['effect']} seed {r['seed']} "
            f"after {r['attempts']} noise draws: {'; '.join(r['failures'])}"
        )
    if easy:
        print("\nEASY cases (fixed magnitudes of fieldtruth.MAGNITUDES)")
        confusion(easy)
        summary(easy)


def confusion(rows: list[dict[str, Any]]) -> None:
    """Rows: the true effects; columns: the named effects."""
    truths = list(dict.fromkeys(str(r["effect"]) for r in rows))
    named = ["none", *CATALOGUE, "unexplained"]
    counts: dict[str, Counter[str]] = defaultdict(Counter)
    for r in rows:
        counts[str(r["effect"])][str(r["named"])] += 1
    print("true \\ named".ljust(16) + "".join(n[:9].rjust(10) for n in named) + "    n")
    for t in truths:
        line = t.ljust(16) + "".join(str(counts[t][n] or ".").rjust(10) for n in named)
        print(line + str(sum(counts[t].values())).rjust(5))


def right_answer(effect: str) -> str:
    """What a correct diagnosis names for a true effect."""
    if effect in ft.UNCATALOGUED:
        return "unexplained"
    return "none" if effect == "control" else effect


def summary(rows: list[dict[str, Any]]) -> None:
    """Per effect: flagged, named right, tie-aware right, interval contains truth, seconds."""
    print("\neffect".ljust(17) + "flagged  named-right  tie-aware  ci-contains-truth  median-s")
    totals: Counter[str] = Counter()
    for t in dict.fromkeys(str(r["effect"]) for r in rows):
        rs = [r for r in rows if r["effect"] == t]
        right = right_answer(t)
        flagged = sum(r["named"] != "none" for r in rs)
        ok = sum(r["named"] == right for r in rs)
        tie = sum(r["named"] == right or right in r["ties"] for r in rs)
        ci = [bool(r["contains"]) for r in rs if r["contains"] is not None]
        print(
            t.ljust(16)
            + f"{flagged}/{len(rs)}".rjust(7)
            + f"{ok}/{len(rs)}".rjust(13)
            + f"{tie}/{len(rs)}".rjust(11)
            + (f"{sum(ci)}/{len(ci)}".rjust(19) if ci else "-".rjust(19))
            + f"{median(rs, 'seconds'):.0f}".rjust(10)
        )
        if t != "control":
            totals.update(n=len(rs), flagged=flagged, tie=tie, ci_n=len(ci), ci=sum(ci))
        else:
            totals.update(controls=len(rs), alarms=flagged)
    if totals["n"]:
        print(
            f"\neffect cases: flagged {pct(totals['flagged'], totals['n'])} (goal >= 95 %), "
            f"named right or tied with the truth listed {pct(totals['tie'], totals['n'])} "
            f"(goal >= 90 %), interval contains the truth {pct(totals['ci'], totals['ci_n'])} "
            f"of catalogue cases (goal >= 90 %)"
        )
    if totals["controls"]:
        print(f"controls: {totals['alarms']} false alarms of {totals['controls']} (goal 0)")
    effects = [r for r in rows if r.get("effect") != "control"]
    controls = [r for r in rows if r.get("effect") == "control"]
    print(
        f"{len(rows)} cases, median {median(rows, 'seconds'):.1f} s per diagnosis "
        f"({len(effects)} effect cases {median(effects, 'seconds'):.1f} s, "
        f"{len(controls)} controls {median(controls, 'seconds'):.1f} s)"
    )


def pct(k: int, n: int) -> str:
    """``k/n (p %)``."""
    return f"{k}/{n} ({100 * k / n:.0f} %)" if n else "-"


def median(rows: list[dict[str, Any]], key: str) -> float:
    """Median of a numeric field over rows that have it (NaN when none)."""
    values = [float(r[key]) for r in rows if r.get(key) is not None]
    return statistics.median(values) if values else float("nan")
