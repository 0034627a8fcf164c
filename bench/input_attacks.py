"""Hostile uploads against a running service: how long each takes and how long health waits.

Starts ``python -m fmuid.api`` on a free loopback port with a fresh data folder, then posts one
hostile submission after the other (a backtracking-bait number cell, a 20k-column header, a spec
with 20k keys, a deeply nested spec, an FMU with a corrupt zip entry, an FMU whose
modelDescription lists a million variables) while a thread polls ``GET /v1/health`` every 10 ms.
It prints, per attack, the answer's status and time, the reason given, and the slowest health
answer seen while the request was open.

    python bench/input_attacks.py [--cases redos-1000,fmu-1M] [--variables 1000000]

The attacks are those of ``testbed/attacks.py`` (also posted by the hardening tests).
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import time
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "testbed"))

from attacks import ATTACKS, HealthWatch, make_attack, post_job, start_service  # noqa: E402

OLD_CELL = r"\s*(?:[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)?\s*"
"""The number-cell pattern before the fix (it backtracks quadratically), for the first table."""


def cell_table() -> None:
    """Print the time of one bad number cell under the old and the current pattern."""
    from fmuid.data.experiment import _CELL

    print(f"{'cell digits':>11} {'old pattern s':>14} {'new pattern s':>14}")
    old = re.compile(OLD_CELL)
    for digits in (1000, 8000, 100_000):
        cell = "1" * digits + "x"
        times = {}
        for label, pattern in (("old", old), ("new", _CELL)):
            if label == "old" and digits > 8000:  # the old pattern would take minutes
                times[label] = float("nan")
                continue
            start = time.perf_counter()
            assert pattern.fullmatch(cell) is None
            times[label] = time.perf_counter() - start
        print(f"{digits:>11} {times['old']:>14.4f} {times['new']:>14.6f}")


def main() -> None:
    """Run the attacks and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default="", help="comma-separated names (default: all)")
    parser.add_argument("--variables", type=int, default=1_000_000)
    parser.add_argument("--cells", action="store_true", help="first time the cell patterns")
    args = parser.parse_args()
    from fmuid.model.builtin import builtin_fmu

    if args.cells:
        cell_table()

    with tempfile.TemporaryDirectory(prefix="fmuid-attacks-") as tmp:
        workdir = Path(tmp)
        chosen = args.cases.split(",") if args.cases else ATTACKS
        proc, url = start_service(workdir)
        try:
            print(f"{'attack':<14} {'status':>6} {'answer s':>9} {'worst health s':>15}  reason")
            for name in chosen:
                spec, csv, fmu = make_attack(name, builtin_fmu("msd"), workdir, args.variables)
                with HealthWatch(url) as watch:
                    start = time.perf_counter()
                    try:
                        response = post_job(url, spec, csv, fmu)
                        status, reason = response.status_code, response.text[:70]
                    except httpx.TimeoutException:
                        status, reason = 0, "no answer within the client timeout"
                    elapsed = time.perf_counter() - start
                print(f"{name:<14} {status:>6} {elapsed:>9.2f} {watch.worst:>15.3f}  {reason}")
        finally:
            proc.terminate()
            proc.wait(timeout=30)


if __name__ == "__main__":
    main()
