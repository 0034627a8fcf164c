"""Median wall time of one 10 s, 5 Hz tractor ramp run: fmuid Simulator vs fmpy.simulate_fmu."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import fmpy
import numpy as np

from fmuid.model.builtin import builtin_fmu
from fmuid.model.simulator import Simulator

RUNS = 200
INPUT_TIME = np.array([0.0, 1.0, 1.5, 10.0])
DELTA = np.array([0.0, 0.0, 0.17452, 0.17452])
OUTPUT_TIME = np.round(np.arange(51) * 0.2, 10)
OUTPUTS = ["gam_t", "gam_i"]


def median_seconds(run: Callable[[], object], runs: int) -> float:
    run()
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
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
            unzipdir, model_description=description, stop_time=10.0, output_interval=0.2,
            input=signal, output=OUTPUTS,
        )  # fmt: skip

    rows = [("fmuid Simulator", median_seconds(ours, RUNS)),
            ("fmpy.simulate_fmu", median_seconds(plain, RUNS))]  # fmt: skip
    print(f"tractor_implement, 10 s ramp, outputs at 5 Hz, median of {RUNS} runs")
    print(f"{'simulator':<20} {'median ms':>10} {'runs/s':>10}")
    for name, seconds in rows:
        print(f"{name:<20} {seconds * 1e3:>10.3f} {1.0 / seconds:>10.0f}")
    sim.close()


if __name__ == "__main__":
    main()
