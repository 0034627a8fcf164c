"""The thesis study as one command: simulate, profile, report (``fmuid demo``).

Each design of :mod:`fmuid.demo.thesis` is simulated at the nominal parameters for each SNR
level, the six tire parameters are profiled, and the report compares with thesis Table 3.3,
compiles the intervals as thesis Figs 3.4, 3.9 and 3.10 and says which design narrows which
parameter.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import fmuid
from fmuid.demo.report import write_study_report
from fmuid.demo.thesis import (
    COMPILATION_GROUPS,
    DESIGNS,
    GRIDS,
    MODEL,
    NOMINAL,
    SNRS,
    THESIS_TABLE_3_3,
    UNITS,
    DatasetRun,
    simulate_dataset,
    study_spec,
)
from fmuid.model.builtin import builtin_fmu
from fmuid.model.fmu import FmuModel
from fmuid.progress import Progress
from fmuid.readable import duration


def run_demo(
    out_dir: Path,
    *,
    grid: str = "full",
    workers: int | None = None,
    progress: Callable[[str], object] = print,
    seed: int = 0,
) -> Path:
    """Run the thesis study and write its report.

    Parameters
    ----------
    out_dir
        Folder of the report (``index.html``, figures, one sub-report per dataset).
    grid
        ``"full"`` (3 designs x 6 SNR levels) or ``"small"`` (ramp 5 Hz and chirp 5 Hz at
        SNR 1000 and 25).
    workers
        Worker processes of each profile study (default: CPU count).
    progress
        Receives one human-readable line per step.
    seed
        Base seed of the noise; each dataset draws from ``(seed, design, SNR)``.

    Returns
    -------
    Path
        The report's ``index.html``.

    Raises
    ------
    ValueError
        If ``grid`` is unknown.

    """
    if grid not in GRIDS:
        raise ValueError(f"grid must be one of {', '.join(GRIDS)}, not {grid!r}")
    start = time.perf_counter()
    designs, snrs = GRIDS[grid]
    progress(f"demo: {len(designs)} designs x {len(snrs)} SNR levels, building the FMU if needed")
    fmu = FmuModel(builtin_fmu(MODEL))  # parsed once, handed to every study and the report
    runs: list[DatasetRun] = []
    total = len(designs) * len(snrs)
    for design in designs:
        for snr in snrs:
            rng = np.random.default_rng((seed, DESIGNS.index(design), SNRS.index(snr)))
            experiment, sigma = simulate_dataset(fmu, design, snr, rng)
            spec = study_spec(sigma)
            tag = f"[{len(runs) + 1}/{total}] {design.name}, SNR {snr:g}"
            progress(f"{tag}: profiling 6 tire parameters (sigma {sigma:.3g} rad/s)")
            t0 = time.perf_counter()
            result = fmuid.profile(
                fmu, [experiment], spec, workers=workers, progress=_Throttle(tag, progress)
            )
            seconds = time.perf_counter() - t0
            labels = ", ".join(
                f"{n} {p.status.split('_')[0]}" for n, p in result.parameters.items()
            )
            progress(f"{tag}: done in {duration(seconds)} ({labels})")
            runs.append(DatasetRun(design, snr, sigma, experiment, spec, result, seconds))
    progress("writing the report")
    index = write_study_report(
        runs,
        Path(out_dir),
        fmu=fmu,
        truth=NOMINAL,
        units=UNITS,
        reference=THESIS_TABLE_3_3,
        reference_case=(DESIGNS[0].name, SNRS[0]),
        groups=COMPILATION_GROUPS,
        grid=grid,
        started=start,
        seed=seed,
        progress=progress,
    )
    progress(f"demo finished in {duration(time.perf_counter() - start)}; report: {index}")
    return index


class _Throttle:
    """Forward engine progress events as text lines, at most one every ``interval`` seconds."""

    def __init__(self, tag: str, sink: Callable[[str], object], interval: float = 10.0):
        self.tag = tag
        self.sink = sink
        self.interval = interval
        self.last = time.perf_counter()

    def __call__(self, event: Progress) -> None:
        now = time.perf_counter()
        if now - self.last >= self.interval:
            self.last = now
            self.sink(f"{self.tag}: {event.stage} {event.done}/{event.total} {event.detail}")
