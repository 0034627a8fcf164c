"""Simulation cost, two tables.

1. Per-sample cost of the co-simulation master loop, native (C, :mod:`fmuid.model.native`)
   and Python (the reference), on long records with an input sample at every output sample
   (610 Hz, as the Silverbox recordings): msd on 4,000 and 65,062 samples, the tractor on
   4,000, msd with feedback terms closed around it (the feedback loop), Reference-FMUs
   (Feedthrough FMI 2.0 with 1 ms midpoint sub-steps, VanDerPol FMI 3.0) when
   ../shared/reference-fmus exists; with the largest difference between the two loops.
2. Median wall time of one 10 s run per FMU kind: the built-in tractor (fmuid Simulator vs
   fmpy.simulate_fmu, and hosted as an FMU with an unreliable reset: a fresh instance per run in
   a simulation process replaced every 50 runs) and the Reference-FMUs (FMI 2.0/3.0,
   co-simulation/model exchange).

``python bench/simulate.py --loops`` prints the first table only.
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import fmpy
import numpy as np

from fmuid.model.builtin import builtin_fmu
from fmuid.model.feedback import Feedback, FeedbackTerm
from fmuid.model.host import HostedSimulator
from fmuid.model.simulator import Simulator

RUNS = 200
HOSTED_RECYCLE = 50
INPUT_TIME = np.array([0.0, 1.0, 1.5, 10.0])
DELTA = np.array([0.0, 0.0, 0.17452, 0.17452])
OUTPUT_TIME = np.round(np.arange(51) * 0.2, 10)
OUTPUTS = ["gam_t", "gam_i"]
REFERENCE_DIR = Path(
    os.environ.get(
        "FMUID_REFERENCE_FMUS", Path(__file__).resolve().parents[2] / "shared" / "reference-fmus"
    )
)
RAMP = {"Float64_continuous_input": np.array([0.0, 0.0, 1.0, 1.0])}
FOREIGN = [  # (file, interface, inputs, outputs)
    ("fmi2/VanDerPol.fmu", "CoSimulation", {}, ["x0", "x1"]),
    ("fmi3/VanDerPol.fmu", "CoSimulation", {}, ["x0", "x1"]),
    ("fmi2/VanDerPol.fmu", "ModelExchange", {}, ["x0", "x1"]),
    ("fmi3/VanDerPol.fmu", "ModelExchange", {}, ["x0", "x1"]),
    ("fmi2/BouncingBall.fmu", "ModelExchange", {}, ["h"]),
    ("fmi2/Feedthrough.fmu", "CoSimulation", RAMP, ["Float64_continuous_output"]),
    ("fmi3/Feedthrough.fmu", "CoSimulation", RAMP, ["Float64_continuous_output"]),
    ("fmi2/Feedthrough.fmu", "ModelExchange", RAMP, ["Float64_continuous_output"]),
]


RATE = 610.0
"""Sample rate [Hz] of the per-sample table (the Silverbox recordings')."""
FRICTION = Feedback(
    (
        FeedbackTerm("f", "x", False, "power", -3.0, 3),
        FeedbackTerm("f", "v", False, "tanh", -0.3, 0.05),
    ),
    1e-3,
)
"""A cubic spring and Coulomb friction closed around msd, steps of at most 1 ms."""
LOOP_CASES = [  # (label, built-in name or Reference-FMU file, input, outputs, samples, feedback)
    ("msd", "msd", "f", ["x", "v"], 4000, None),
    ("msd", "msd", "f", ["x", "v"], 65062, None),
    ("msd + feedback, 1 ms steps", "msd", "f", ["x", "v"], 4000, FRICTION),
    ("tractor_implement", "tractor_implement", "delta", ["gam_t", "gam_i"], 4000, None),
    (
        "Feedthrough FMI 2.0 CS",
        "fmi2/Feedthrough.fmu",
        "Float64_continuous_input",
        ["Float64_continuous_output"],
        4000,
        None,
    ),
    ("VanDerPol FMI 3.0 CS", "fmi3/VanDerPol.fmu", None, ["x0", "x1"], 4000, None),
]


def loop_rows() -> list[tuple[str, int, float, float, float]]:
    """Per-sample cost [s] of the native and the Python loop, and their largest difference."""
    rows = []
    for label, fmu, name, outputs, n, feedback in LOOP_CASES:
        path = REFERENCE_DIR / fmu if fmu.endswith(".fmu") else builtin_fmu(fmu)
        if not path.is_file():
            continue
        t = np.arange(n) / RATE
        u = 0.1 * np.sin(2 * np.pi * 0.7 * t) + 0.05 * np.sin(2 * np.pi * 9.3 * t)
        inputs = {name: (40.0 if name == "f" else 1.0) * u} if name else {}
        t_in = t if name else t[:1]
        sim = Simulator(path)
        runs = max(3, min(50, 200_000 // n))
        cost, result = [], []
        run = partial(sim.simulate, {}, t_in, inputs, t, outputs, feedback)
        for native in (True, False):
            sim.native = native
            result.append(run())
            cost.append(median_seconds(run, runs if native else 3) / n)
        sim.close()
        rows.append((label, n, cost[0], cost[1], float(np.max(np.abs(result[0] - result[1])))))
    return rows


def print_loops() -> None:
    """Print the per-sample table."""
    print(f"master loop per sample, {RATE:g} Hz records, an input sample at every output sample")  # noqa: T201
    print(
        f"{'FMU':<26} {'samples':>8} {'native us':>10} {'Python us':>10} {'speed-up':>9} "  # noqa: T201
        f"{'max |diff|':>11}"
    )
    for label, n, native, python, diff in loop_rows():
        print(
            f"{label:<26} {n:>8} {native * 1e6:>10.3f} {python * 1e6:>10.2f} "  # noqa: T201
            f"{python / native:>8.0f}x {diff:>11.2g}"
        )


def median_seconds(run: Callable[[], object], runs: int) -> float:
    """Median wall time [s] of ``runs`` calls after one warm-up call."""
    run()
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def tractor_rows() -> list[tuple[str, str, float]]:
    """The built-in tractor: fmuid's Simulator and fmpy.simulate_fmu."""
    path = builtin_fmu("tractor_implement")
    sim = Simulator(path)
    signal = np.array(
        list(zip(INPUT_TIME, DELTA, strict=True)), dtype=[("time", float), ("delta", float)]
    )
    unzipdir = fmpy.extract(str(path))
    description = fmpy.read_model_description(unzipdir)

    def ours() -> object:
        return sim.simulate({}, INPUT_TIME, {"delta": DELTA}, OUTPUT_TIME, OUTPUTS)

    def plain() -> object:
        return fmpy.simulate_fmu(
            unzipdir,
            model_description=description,
            stop_time=10.0,
            output_interval=0.2,
            input=signal,
            output=OUTPUTS,
        )

    hosted = HostedSimulator(path, runs_per_process=HOSTED_RECYCLE)

    def fresh() -> object:
        return hosted.simulate({}, INPUT_TIME, {"delta": DELTA}, OUTPUT_TIME, OUTPUTS)

    rows = [
        ("tractor_implement (fmuid Simulator)", sim.input_handling, median_seconds(ours, RUNS)),
        ("tractor_implement (fmpy.simulate_fmu)", "fmpy", median_seconds(plain, RUNS)),
        (
            f"tractor_implement (HostedSimulator, {HOSTED_RECYCLE} runs/process)",
            hosted.instances,
            median_seconds(fresh, RUNS),
        ),
    ]
    start = time.perf_counter()
    for _ in range(RUNS):
        fresh()
    mean = (time.perf_counter() - start) / RUNS
    rows.append(("  the same, mean over 200 runs with the process forks", "", mean))
    sim.close()
    hosted.close()
    return rows


def foreign_rows(runs: int) -> list[tuple[str, str, float]]:
    """Reference-FMUs through fmuid's Simulator, 10 s with outputs at 5 Hz."""
    rows = []
    for name, interface, inputs, outputs in FOREIGN:
        path = REFERENCE_DIR / name
        if not path.is_file():
            continue
        sim = Simulator(path, interface=interface)
        t_in = INPUT_TIME if inputs else INPUT_TIME[:1]
        seconds = median_seconds(
            lambda sim=sim, t_in=t_in, inputs=inputs, outputs=outputs: sim.simulate(
                {}, t_in, inputs, OUTPUT_TIME, outputs
            ),
            runs,
        )
        rows.append((f"{name} ({sim.model.kind_label})", sim.input_handling, seconds))
        sim.close()
    return rows


def pythonfmu_rows(runs: int) -> list[tuple[str, str, float]]:
    """The pythonfmu first-order lag of the tests (built here), constant and ramp input."""
    try:
        from pythonfmu import FmuBuilder
    except ImportError:
        return []
    source = Path(__file__).resolve().parents[1] / "tests" / "pythonfmu_src" / "first_order.py"
    with tempfile.TemporaryDirectory() as out:
        sim = Simulator(FmuBuilder.build_FMU(source, dest=out))
        rows = []
        for label, u in (("constant input", np.ones(4)), ("ramp input", DELTA)):
            seconds = median_seconds(
                lambda u=u: sim.simulate({}, INPUT_TIME, {"u": u}, OUTPUT_TIME, ["y"]), runs
            )
            rows.append(
                (
                    f"pythonfmu FirstOrder, {label} ({sim.model.kind_label})",
                    sim.input_handling,
                    seconds,
                )
            )
        sim.close()
    return rows


def main() -> None:
    """Print the tables."""
    print_loops()
    if "--loops" in sys.argv[1:]:
        return
    print()  # noqa: T201
    rows = tractor_rows() + foreign_rows(RUNS // 4) + pythonfmu_rows(RUNS // 20)
    print("10 s runs, outputs at 5 Hz (a 1 s ramp input where the FMU has one); median ms")  # noqa: T201
    print(f"{'FMU':<58} {'median ms':>10} {'runs/s':>8}  input handling")  # noqa: T201
    for name, handling, seconds in rows:
        print(f"{name:<58} {seconds * 1e3:>10.3f} {1.0 / seconds:>8.0f}  {handling}")  # noqa: T201
    if not any(".fmu" in n for n, _, _ in rows):
        print(f"(no Reference-FMUs in {REFERENCE_DIR})")  # noqa: T201


if __name__ == "__main__":
    main()
