"""The report of the thesis study (``fmuid demo``).

Comparison with the thesis, compilations, experiment advice and one sub-report per dataset.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from fmuid.demo.advice import StudyCase, advice_tables, study_verdict
from fmuid.demo.compilation import ci_compilation_figure, ci_entries_from_profile
from fmuid.estimation.series import residual_series
from fmuid.plots import (
    fit_figure,
    profile_figure,
    trajectory_band_figure,
)
from fmuid.profiling.band import trajectory_band
from fmuid.readable import duration, interval, interval_end
from fmuid.report.page import HtmlPage, file_slug, with_unit
from fmuid.report.writer import write_report

if TYPE_CHECKING:
    from fmuid.demo.thesis import DatasetRun
    from fmuid.model.fmu import FmuModel


def write_study_report(
    runs: Sequence[DatasetRun],
    directory: Path,
    *,
    fmu: FmuModel,
    truth: Mapping[str, float],
    units: Mapping[str, str],
    reference: Mapping[str, tuple[float, float, float]],
    reference_case: tuple[str, float],
    groups: Mapping[str, Sequence[str]],
    grid: str,
    started: float,
    seed: int,
    progress: Callable[[str], object] = lambda line: None,
) -> Path:
    """Write the study's ``index.html`` and a sub-report per dataset.

    Parameters
    ----------
    runs
        The datasets and their profile studies.
    directory
        Output folder.
    fmu
        The parsed FMU the data were simulated with.
    truth
        Parameter values that made the data.
    units
        Unit of each parameter.
    reference
        The thesis's (estimate, CI lower, CI upper) per parameter for ``reference_case``.
    reference_case
        Design name and SNR of the thesis table.
    groups
        Compilation figures across designs: title -> parameters (thesis Figs 3.9, 3.10).
    grid
        Name of the grid run.
    started
        ``time.perf_counter()`` when the study began: the page states the wall time from then
        until it is written, drawing included.
    seed
        Base seed of the noise draws.
    progress
        Receives one line per drawing step.

    Returns
    -------
    Path
        The ``index.html``.

    """
    from fmuid.stages import make_problem

    directory = Path(directory)
    page = HtmlPage(directory, "fmuid demo: identifiability of the tractor-implement tire model")
    cases = [StudyCase(r.design.name, r.snr, r.result) for r in runs]
    designs = list(dict.fromkeys(r.design.name for r in runs))
    snrs = sorted({r.snr for r in runs}, reverse=True)
    page.verdict(study_verdict(cases))
    method_at = len(page.blocks)
    ref = next(
        (r for r in runs if r.design.name == reference_case[0] and r.snr == reference_case[1]),
        None,
    )
    if ref is not None:
        page.heading(f"Beside thesis Table 3.3 ({reference_case[0]}, SNR {reference_case[1]:g})")
        rows = []
        for name, prof in ref.result.parameters.items():
            est, lo, hi = reference.get(name, (math.nan, math.nan, math.nan))
            rows.append(
                [
                    name,
                    units.get(name, ""),
                    truth.get(name),
                    est,
                    interval((lo, hi)),
                    prof.estimate,
                    interval(prof.ci_simultaneous),
                    prof.status.replace("_", " "),
                ]
            )
        page.table(
            [
                "parameter",
                "unit",
                "true",
                "thesis estimate",
                "thesis CI (68% simult.)",
                "fmuid estimate",
                "fmuid CI (68% simult.)",
                "fmuid label",
            ],
            rows,
            table_id="summary",
            caption="True values, estimates and 68% simultaneous likelihood-based CIs",
        )
        page.figure(
            profile_figure(ref.result),
            "profiles_reference",
            f"Profile likelihoods, {reference_case[0]}, SNR {reference_case[1]:g} "
            "(as thesis Fig 3.3).",
        )
    page.heading("Experiment advice")
    page.paragraph(
        "One table per design. Each cell: the width of the 68% simultaneous CI at that SNR "
        "(dec: decades, log10(upper/lower); rel.: (upper - lower)/estimate), green where this "
        "design is the narrowest of all designs at that SNR. Red: not identifiable (PNI "
        "practically, SNI structurally), with the open ends and the parameters it trades "
        "against along its profile (decades per decade, read only where the profile rises)."
    )
    for table in advice_tables(cases):
        page.table(
            table.header,
            table.rows,
            table_id=f"advice_{file_slug(table.design)}",
            caption=f"Design: {table.design}",
        )
    page.heading("All datasets")
    names = list(runs[0].result.parameters) if runs else []
    page.table(
        [
            "design",
            "SNR",
            "sigma [rad/s]",
            "chi2",
            "n_data",
            "wall time",
            *(with_unit(n, units.get(n)) for n in names),
        ],
        [
            [
                r.design.name,
                r.snr,
                r.sigma,
                r.result.chi2,
                r.result.fit.n_data,
                duration(r.seconds),
                *(
                    _cell(r.result.parameters[n].ci_simultaneous, r.result.parameters[n].status)
                    for n in names
                ),
            ]
            for r in runs
        ],
        table_id="datasets",
        caption="68% simultaneous CIs per dataset (PNI: practically, SNI: structurally "
        "non-identifiable)",
    )
    progress("drawing the compilations")
    page.heading("Compilations")
    for design in designs:
        entries = [
            e
            for r in runs
            if r.design.name == design
            for e in ci_entries_from_profile(r.result, f"SNR {r.snr:g}", true_values=truth)
        ]
        page.figure(
            ci_compilation_figure(entries, title=f"68% simultaneous CIs, {design}"),
            f"compilation_{design}",
            f"CIs per SNR level, {design} (as thesis Fig 3.4).",
        )
    for title, params in groups.items():
        entries = [
            e
            for design in designs
            for r in runs
            if r.design.name == design
            for e in ci_entries_from_profile(
                r.result, f"SNR {r.snr:g}", group=design, true_values=truth
            )
            if e.parameter in params
        ]
        page.figure(
            ci_compilation_figure(entries, ncols=len(params), title=title),
            f"compilation_{title}",
            f"{title} across designs (as thesis Figs 3.9/3.10).",
        )
    progress("drawing the trajectory band and the fit")
    noisy = min((r for r in runs if r.design.name == designs[0]), key=lambda r: r.snr)
    problem = make_problem(fmu, [noisy.experiment], noisy.spec)
    page.figure(
        trajectory_band_figure(trajectory_band(problem, noisy.result)),
        "trajectory_band",
        f"Trajectories inside the simultaneous CIs, {noisy.design.name}, SNR "
        f"{noisy.snr:g} (as thesis Fig 3.5).",
    )
    page.figure(
        fit_figure(residual_series(problem, noisy.result.fit.estimates)),
        "fit_noisiest",
        f"Fit and weighted residuals, {noisy.design.name}, SNR {noisy.snr:g}.",
    )
    page.heading("Per-dataset reports")
    for k, r in enumerate(runs, 1):
        slug = file_slug(f"{r.design.slug}_snr{r.snr:g}")
        progress(f"drawing the per-dataset reports: {k}/{len(runs)}")
        write_report(r.result, directory / slug)
        page.link(
            f"{slug}/index.html", f"{r.design.name}, SNR {r.snr:g}: profiles and parameter paths"
        )
    elapsed = time.perf_counter() - started
    page.paragraph(_method(fmu.path.name, grid, designs, snrs, runs, seed, elapsed), at=method_at)
    return page.write()


def _method(
    fmu: str,
    grid: str,
    designs: Sequence[str],
    snrs: Sequence[float],
    runs: Sequence[DatasetRun],
    seed: int,
    elapsed: float,
) -> str:
    """Say what was run, how the noise was made and how long it all took."""
    return (
        f"Thesis section 3.2.3.1 re-run on the FMU {fmu}: grid '{grid}' ({len(designs)} "
        f"designs x {len(snrs)} SNR levels = {len(runs)} datasets), six tire parameters "
        "profiled in each. Each dataset simulates its design's steer input at the nominal "
        "parameters and adds Gaussian noise to both yaw rates with sigma = max|gam_t| / SNR "
        "(thesis eq. 3.28): each cell is one noise draw, seeded by (seed, design, SNR level) "
        f"with seed {seed}. Wall time {duration(elapsed)} on {os.cpu_count()} CPU cores, "
        f"drawing this report included (profiles alone: "
        f"{duration(sum(r.seconds for r in runs))})."
    )


def _cell(ci: tuple[float | None, float | None], status: str) -> str:
    tag = {"practically_non_identifiable": " PNI", "structurally_non_identifiable": " SNI"}
    lo, hi = (interval_end(end, 3) for end in ci)
    return f"{lo} \u2013 {hi}{tag.get(status, '')}"
