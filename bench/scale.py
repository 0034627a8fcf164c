"""Scale-out: profiles, diagnoses and designs on a dask cluster of 1, 2 and 4 worker processes.

Three workloads of the tractor (``testbed/concealed.py``'s input-offset case seed 0: two
experiments, six tire parameters):

- ``profile``: ``fmuid.profile`` of the six tire parameters (branches as dask tasks);
- ``diagnose``: ``fmuid.diagnose`` without the re-profiles of the original parameters (the
  candidate scan and the profiles of the added parameters as dask tasks);
- ``design``: ``bench/design.py``'s study space at SNR 25 (2 candidates per family, 1 design
  verified on 2 draws; one trial or one draw per task).

Each runs once in this process (the reference), then on a ``LocalCluster`` of 1, 2 and 4
separate worker processes (1 thread each). The table gives the wall times, the speed-up over
one worker and whether the result's numbers equal the reference's (the JSON without wall
times and provenance; numbers to 1e-9). A machine with fewer cores than workers cannot speed
up further.

    python bench/scale.py [--workers 1 2 4] [--only profile diagnose design]
"""

from __future__ import annotations

import argparse
import sys
import time
from argparse import Namespace
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "testbed"))

import concealed as cc  # noqa: E402
import fmuid  # noqa: E402
from design import make_space, make_spec, ramp_sigma  # noqa: E402
from fmuid.discrepancy import DiagnoseOptions  # noqa: E402
from fmuid.model.builtin import builtin_fmu  # noqa: E402
from operational import study_spec  # noqa: E402

Workload = Callable[[Any], Any]


def workloads() -> dict[str, Workload]:
    """Each workload as a function of the executor (``None``: this process)."""
    fmu = builtin_fmu("tractor_implement")
    case = cc.get_case("input_offset", 0, None).case
    spec = study_spec()
    options = DiagnoseOptions(absorbed=False, discriminate=False)
    design_args = Namespace(candidates=2, verify=1, draws=2, points=1)
    space = make_space(ramp_sigma(fmu, 25.0), design_args)
    return {
        "profile": lambda ex: fmuid.profile(fmu, case.experiments, spec, workers=1, executor=ex),
        "diagnose": lambda ex: fmuid.diagnose(
            fmu, case.experiments, spec, options=options, executor=ex
        ),
        "design": lambda ex: fmuid.design(fmu, make_spec(), space, workers=1, executor=ex),
    }


def numbers(result: Any) -> dict[str, Any]:
    """The result's JSON without what differs between runs (wall times, provenance)."""
    out = dict(result.to_dict())
    out["simulations"] = out.pop("cost", {}).get("simulations")
    out.pop("provenance", None)
    return out


def close(a: Any, b: Any, rel: float = 1e-9) -> bool:
    """Whether two JSON values are equal, numbers to ``rel``."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(close(a[k], b[k], rel) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(close(x, y, rel) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) <= rel * max(abs(a), abs(b)) or a == b
    return a == b


def timed(work: Workload, executor: Any) -> tuple[Any, float]:
    t0 = time.perf_counter()
    result = work(executor)
    return result, time.perf_counter() - t0


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--only", nargs="+", default=["profile", "diagnose", "design"])
    args = parser.parse_args()
    from distributed import Client, LocalCluster

    todo = {k: v for k, v in workloads().items() if k in args.only}
    reference = {name: timed(work, None) for name, work in todo.items()}
    walls: dict[str, dict[int, tuple[float, bool]]] = {name: {} for name in todo}
    for n in args.workers:
        with (
            LocalCluster(
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None
            ) as cluster,
            Client(cluster) as client,
        ):
            for name, work in todo.items():
                result, wall = timed(work, client)
                walls[name][n] = (wall, close(numbers(result), numbers(reference[name][0])))
    head = " ".join(f"{f'{n} worker(s) s':>14} {'x':>5}" for n in args.workers)
    print(f"{'workload':<9} {'local s':>8} {head} same numbers")
    for name, by_n in walls.items():
        first = by_n[args.workers[0]][0]
        cells = " ".join(f"{wall:14.1f} {first / wall:5.2f}" for wall, _ in by_n.values())
        same = all(ok for _, ok in by_n.values())
        print(f"{name:<9} {reference[name][1]:8.1f} {cells} {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
