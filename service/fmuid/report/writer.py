"""``write_report``: one self-contained ``index.html`` with PNG figures for any fmuid result."""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib
from matplotlib.figure import Figure

from fmuid.errors import FmuidError
from fmuid.estimation.result import FitResult
from fmuid.estimation.series import residual_series
from fmuid.plots import (
    fit_figure,
    parameter_paths_figure,
    profile_figure,
    trajectory_band_figure,
)
from fmuid.profiling.band import trajectory_band
from fmuid.profiling.result import ParameterProfile, ProfileResult
from fmuid.readable import duration, interval
from fmuid.report.diagnosis import diagnosis_sections
from fmuid.report.page import HtmlPage, fmt
from fmuid.report.verdict import profile_verdict, quality_text

if TYPE_CHECKING:
    from fmuid.data import Experiment, Spec
    from fmuid.estimation.problem import Problem

logger = logging.getLogger(__name__)


def write_report(
    result: FitResult | ProfileResult | Any,
    directory: Path,
    *,
    fmu: Path | str | None = None,
    experiments: Sequence[Experiment] | None = None,
    spec: Spec | None = None,
    problem: Problem | None = None,
    extra_figures: Mapping[str, Figure] | None = None,
) -> Path:
    """Write an HTML report of a fit, a profile study or a diagnosis.

    The page holds a summary table (per parameter: estimate, simultaneous and pointwise CI,
    label, bounds), the study's numbers (chi2, number of data, thresholds, sigma and how it was
    obtained, cost), the structural check, then the figures. With the fitting problem the
    engine computed the result on, the fit overlay with residual diagnostics and (for a
    profile) the trajectory band are drawn too. A diagnosis (any object
    whose ``to_dict()`` follows the contract's "Diagnose result") shows its summary and the
    figures of ``fmuid.plots.diagnosis_figures``.

    Parameters
    ----------
    result
        ``FitResult``, ``ProfileResult`` or a diagnosis.
    directory
        Folder for ``index.html`` and the PNG files (created if missing).
    fmu, experiments, spec
        The study's inputs, for a caller that does not have the problem (e.g. a process that
        draws a stored result): it is built from them once, here.
    problem
        The fitting problem the engine computed the result on (``fmuid.stages.make_problem``);
        by default the one the result carries (``fmuid.fit``, ``profile`` and ``diagnose`` set
        it), so that nothing (FMU, sigma estimate) is derived again.
    extra_figures
        More figures to append, by caption.

    Returns
    -------
    Path
        The ``index.html`` written.

    """
    from fmuid.experiment_design import DesignResult

    if isinstance(result, DesignResult):
        from fmuid.report.design import write_design_report

        return write_design_report(result, Path(directory))
    problem = problem or getattr(result, "problem", None)
    if problem is None and fmu is not None and experiments is not None and spec is not None:
        from fmuid.estimation.problem import Problem

        problem = Problem(fmu, experiments, spec)
    with matplotlib.rc_context({"text.parse_math": False}):  # a '$' in a name is text
        if isinstance(result, ProfileResult):
            page = HtmlPage(Path(directory), f"Profile likelihood: {result.fit.model_name}")
            _profile_sections(page, result, problem)
        elif isinstance(result, FitResult):
            page = HtmlPage(Path(directory), f"Fit: {result.model_name}")
            _fit_sections(page, result, problem)
        else:
            page = HtmlPage(Path(directory), "Model discrepancy diagnosis")
            diagnosis_sections(page, result, problem)
        for caption, fig in (extra_figures or {}).items():
            page.figure(fig, f"extra_{caption}", caption)
        return page.write()


def _profile_sections(page: HtmlPage, result: ProfileResult, problem: Problem | None) -> None:
    fit = result.fit
    units = fit.units
    page.verdict(profile_verdict(result))
    page.heading("Summary")
    level = f"{result.confidence:.0%}"
    page.table(
        [
            "parameter",
            "unit",
            "estimate",
            f"CI simultaneous ({level})",
            f"CI pointwise ({level})",
            "label",
            "why",
            "quality",
            "bounds",
            "scale",
        ],
        [
            [
                name,
                units.get(name, "\u2014"),
                p.estimate,
                interval(p.ci_simultaneous),
                interval(p.ci_pointwise),
                _label(p),
                p.status_reason or "\u2014",
                quality_text(p.quality),
                interval((p.lower, p.upper)),
                p.scale,
            ]
            for name, p in result.parameters.items()
        ],
        table_id="summary",
        caption="Estimates and likelihood-based confidence intervals (in the unit given)",
    )
    if result.better_optimum_found:
        page.paragraph(
            "A better optimum than the fit was found while profiling; the profiles were "
            "recomputed from it.",
            note=True,
        )
    _study_numbers(page, fit, result.confidence, result.thresholds, result.cost.to_dict())
    _structural(page, result.structural_check)
    page.heading("Figures")
    page.figure(
        profile_figure(result),
        "profiles",
        "Profile likelihoods (black), quadratic approximation (gray), pointwise and "
        "simultaneous thresholds (red dashed), estimate (asterisk); red dots: another "
        "parameter on a bound; crosses: failed points.",
    )
    for name in result.parameters:
        page.figure(
            parameter_paths_figure(result, name),
            f"paths_{name}",
            f"How the other parameters move along the profile of {name}.",
        )
    page.csv_file(
        "profile_path",
        result.path_rows(),
        "Every profile's path as a table (CSV): per point the profiled value, chi2, its rise "
        "above the optimum, whether it is inside the simultaneous threshold, and the "
        "re-fitted values of the other parameters.",
    )
    if problem is not None:
        _try_figure(
            page,
            "fit",
            "Data and fitted model; weighted residuals, Q-Q plot and histogram.",
            lambda: fit_figure(residual_series(problem, fit.estimates)),
        )
        _try_figure(
            page,
            "trajectory_band",
            "Outputs over parameter sets inside the simultaneous CI.",
            lambda: trajectory_band_figure(trajectory_band(problem, result)),
        )


def _label(p: ParameterProfile) -> str:
    label = p.status.replace("_", " ")
    if p.limited_by:
        label += f" (CI end set by {', '.join(p.limited_by)} on a bound)"
    return label


def _fit_sections(page: HtmlPage, fit: FitResult, problem: Problem | None) -> None:
    info = fit.to_dict()["parameters"]
    on_bound = [n for n in fit.names if info[n]["at_bound"]]
    page.verdict(
        [
            f"Best fit of {len(fit.names)} parameters to {fit.n_data} data: chi2 = "
            f"{fmt(fit.chi2)}.",
            f"On a bound: {', '.join(on_bound)}." if on_bound else "No estimate is on a bound.",
            "Run a profile study for confidence intervals and identifiability labels.",
        ]
    )
    page.heading("Summary")
    page.table(
        ["parameter", "unit", "estimate", "label", "bounds", "scale"],
        [
            [
                n,
                fit.units.get(n, "\u2014"),
                fit.estimates[n],
                "on a bound" if info[n]["at_bound"] else "inside bounds",
                interval((fit.lower[n], fit.upper[n])),
                s,
            ]
            for n, s in zip(fit.names, fit.scales, strict=True)
        ],
        table_id="summary",
        caption="Best-fit parameters (run a profile study for confidence intervals)",
    )
    _study_numbers(page, fit, None, None, fit.cost.to_dict())
    if fit.message:
        page.paragraph(f"Optimiser: {fit.message}")
    if problem is not None:
        page.heading("Figures")
        _try_figure(
            page,
            "fit",
            "Data and fitted model; weighted residuals, Q-Q plot and histogram.",
            lambda: fit_figure(residual_series(problem, fit.estimates)),
        )


def _study_numbers(
    page: HtmlPage,
    fit: FitResult,
    confidence: float | None,
    thresholds: Mapping[str, float] | None,
    cost: Mapping[str, float],
) -> None:
    rows: list[list[object]] = [
        ["model", f"{fit.model_name} (sha256 {fit.fmu_sha256[:12]})"],
        ["chi2 at the optimum", fit.chi2],
        ["number of data", fit.n_data],
    ]
    if confidence is not None and thresholds is not None:
        rows.append(["confidence", confidence])
        rows += [[f"threshold {k} (chi2 rise)", v] for k, v in thresholds.items()]
    rows += [
        [f"sigma {o}", f"{fmt(v)}{_space(fit.units.get(o))} ({fit.sigma_method.get(o, '')})"]
        for o, v in fit.sigma.items()
    ]
    rows += [[f"fixed {n}", f"{fmt(v)}{_space(fit.units.get(n))}"] for n, v in fit.fixed.items()]
    rows += [
        ["global search", fit.global_search],
        ["simulations", int(cost["simulations"])],
        ["wall time", duration(float(cost["seconds"]))],
    ]
    page.table(["quantity", "value"], rows, table_id="study", caption="Study")


def _space(unit: str | None) -> str:
    return f" {unit}" if unit else ""


def _structural(page: HtmlPage, check: Mapping[str, Any]) -> None:
    page.heading("Structural check")
    values = check.get("singular_values", [])
    page.paragraph(
        "Singular values of the weighted sensitivity matrix: "
        + (", ".join(f"{v:.3g}" for v in values) if values else "none reported")
    )
    combos = check.get("non_identifiable_combinations", [])
    if combos:
        page.table(
            ["parameters", "direction", "meaning"],
            [
                [
                    ", ".join(c.get("parameters", [])),
                    ", ".join(f"{d:.3g}" for d in c.get("direction", [])),
                    c.get("meaning", ""),
                ]
                for c in combos
            ],
            table_id="structural",
        )
    else:
        page.paragraph("No non-identifiable parameter combination was found.")


def _try_figure(page: HtmlPage, name: str, caption: str, draw: Callable[[], Figure]) -> None:
    """Add a figure that needs simulations; a failed simulation is reported, not raised."""
    try:
        fig = draw()
    except FmuidError as error:
        logger.warning("figure %s not drawn: %s", name, error)
        page.paragraph(f"Figure '{name}' could not be drawn: {error}", note=True)
        return
    page.figure(fig, name, caption)
