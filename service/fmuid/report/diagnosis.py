"""The report page of a diagnosis: the verdict first, then plain tables and the figures."""

from __future__ import annotations

import logging
import re
from typing import Any

from fmuid.discrepancy.catalogue import study_catalogue
from fmuid.discrepancy.series import diagnosis_series
from fmuid.errors import FmuidError
from fmuid.estimation.problem import Problem
from fmuid.experiment_design.discriminate import discrimination_from_dict
from fmuid.plots import diagnosis_figures
from fmuid.plots.levels import level_figure
from fmuid.readable import duration, interval, p_text, p_value
from fmuid.report.design import discrimination_section
from fmuid.report.page import Cell, HtmlPage, fmt

logger = logging.getLogger(__name__)

TEST_NAMES = {
    "catalogue_scan": "catalogue scan (best candidate, min-P adjusted)",
    "experiments_disagree": "experiments want different parameters",
    "residual_whiteness": "residual whiteness (Ljung-Box)",
    "input_cross_correlation": "residual-input cross-correlation",
    "residual_bias": "residual mean",
    "chi2_goodness_of_fit": "chi2 against the noise",
    "equal_predictions": "equal predictions (within the noise)",
}


FIGURE_CAPTIONS = {
    "fit": "Data, the base model and the augmented model, per experiment and output.",
    "residuals": "Weighted residuals of both models; shaded: the located time windows.",
    "spectrum": "Residual periodogram against the white-noise floor; shaded: the located band.",
    "levels": "The base fit's weighted residual against each output's level and its rate "
    "(binned means and their standard errors).",
}

PLAIN_CAPTIONS = {
    "fit": "Data and the fitted model, per experiment and output.",
    "residuals": "Weighted residuals of the fitted model; shaded: the located time windows.",
    "spectrum": "Residual periodogram against the white-noise floor; shaded: the located band.",
    "levels": FIGURE_CAPTIONS["levels"],
}
"""Captions when nothing was added (no augmented model to compare)."""


def _params(values: dict[str, Any], units: dict[str, str]) -> str:
    return ", ".join(f"{k} = {fmt(v)}{_space(units.get(k))}" for k, v in values.items())


def _readable(text: object) -> str:
    """Return a sentence with a p-value that underflowed to zero written ``p < 1e-300``."""
    return re.sub(r"\bp = 0(?![.\d])", p_text(0.0), str(text or ""))


def _p(value: float | None) -> Cell:
    return Cell(p_value(value, 3), "num")


def _space(unit: str | None) -> str:
    return f" {unit}" if unit else ""


def _where(test: dict[str, Any]) -> str:
    return " / ".join(str(test[k]) for k in ("experiment", "output") if test.get(k)) or "all"


def _tables(page: HtmlPage, d: dict[str, Any], units: dict[str, str]) -> None:
    added = d.get("added_parameters") or {}
    if added:
        page.table(
            ["added parameter", "estimate", "unit", "interval", "excludes the off value"],
            [
                [
                    n,
                    v.get("estimate"),
                    v.get("unit", ""),
                    interval(v.get("ci") or (None, None)),
                    "yes" if v.get("excludes_off") else "no",
                ]
                for n, v in added.items()
            ],
            caption="Parameters of the added physics (profile-likelihood interval)",
        )
    ties = [t for t in d.get("indistinguishable", []) if isinstance(t, dict)]
    if ties:
        page.table(
            ["equally good effect", "parameters", "chi2", "test", "p-value"],
            [
                [
                    t["effect"],
                    _params(t.get("parameters", {}), units),
                    t.get("chi2"),
                    str(t.get("test", "")).replace("_", " "),
                    _p(t.get("p_value")),
                ]
                for t in ties
            ],
            caption="Explanations this data cannot tell apart from the named one",
        )
    absorbed = d.get("absorbed") or {}
    if absorbed:
        page.table(
            ["parameter", "unit", "before", "status before", "after", "status after", "absorbs"],
            [
                [
                    n,
                    units.get(n, "\u2014"),
                    f"{fmt(a['before']['estimate'])} {interval(a['before']['ci'])}",
                    a["before"]["status"].replace("_", " "),
                    f"{fmt(a['after']['estimate'])} {interval(a['after']['ci'])}",
                    a["after"]["status"].replace("_", " "),
                    "; ".join(a.get("reasons") or []) or "no",
                ]
                for n, a in absorbed.items()
            ],
            caption="The original parameters without and with the added term",
        )
    if d.get("evidence"):
        page.table(
            ["test", "where", "p-value"],
            [
                [TEST_NAMES.get(e["test"], e["test"]), _where(e), _p(e.get("p_value"))]
                for e in d["evidence"]
            ],
            caption="Evidence of the mismatch (tests rejected at the family-wise level)",
        )
    if d.get("candidates"):
        page.table(
            ["effect", "parameters", "chi2", "LR statistic", "p-value", "adjusted p", "round"],
            [
                [
                    c["effect"],
                    _params(c.get("parameters", {}), units),
                    c.get("chi2"),
                    c.get("statistic"),
                    _p(c.get("p_value")),
                    _p(c.get("p_adjusted")),
                    c.get("stage", 1),
                ]
                for c in d["candidates"]
            ],
            caption="Every candidate of the catalogue",
        )
    correction = d.get("generic_correction")
    if correction:
        dyn = correction.get("dynamics") or {}
        mode = dyn.get("mode")
        lead = dyn.get("leads")
        share = correction.get("structure_fraction")
        before, after = fmt(correction["chi2_before"]), fmt(correction["chi2_after"])
        share_text = "not given (the correction reaches the noise floor)"
        if share is not None:
            share_text = f"{share:.0%}"
        mode_text = "none found"
        if mode:
            hz, zeta = fmt(mode["frequency_hz"], 3), fmt(mode["damping"], 2)
            mode_text = f"{hz} Hz, damping ratio {zeta}"
        lead_text = "none"
        if lead:
            lead_text = f"{lead['output']} leads {lead['other']} by {fmt(lead['seconds'], 3)} s"
        band = interval(dyn["frequency_hz"]) + " Hz" if dyn.get("frequency_hz") else "none"
        rows = [
            ["model", correction.get("model")],
            ["chi2 before / after", f"{before} / {after}"],
            ["noise floor", correction.get("noise_chi2")],
            ["share of the misfit that is structure", share_text],
            ["extra mode", mode_text],
            ["band", band],
            ["leading output", lead_text],
        ]
        page.table(["generic correction", "value"], rows, caption="What the misfit looks like")


def diagnosis_sections(page: HtmlPage, diagnosis: Any, problem: Problem | None) -> None:
    """Add the verdict, the tables and (with the problem) the figures of a diagnosis."""
    d = diagnosis.to_dict()
    units = _units(problem)
    units.update(d.get("units") or {})
    added = d.get("added_parameters") or {}
    units.update({n: a["unit"] for n, a in added.items() if a.get("unit")})
    page.verdict([_readable(d.get("verdict", "")), _readable(d.get("description"))])
    page.heading("Summary")
    if d.get("mismatch"):
        _mismatch_summary(page, d, units)
    else:
        _no_mismatch_summary(page, d, units)
    _effects_and_validation(page, d)
    _tables(page, d, units)
    _whiteness(page, d)
    _settling_test(page, d.get("discriminating_experiment"))
    _cost(page, d.get("cost") or {})
    if problem is None:
        return
    try:
        figures = diagnosis_figures(diagnosis, diagnosis_series(diagnosis, problem))
    except FmuidError as error:
        logger.warning("diagnosis figures not drawn: %s", error)
        page.paragraph(f"Figures not drawn: {error}", note=True)
        return
    levels = (d.get("location") or {}).get("levels")
    if levels:
        figures["levels"] = level_figure(levels)
    captions = FIGURE_CAPTIONS if d.get("added_parameters") else PLAIN_CAPTIONS
    page.heading("Figures")
    for name, fig in figures.items():
        page.figure(fig, f"diagnose_{name}", captions.get(name, name))


def _mismatch_summary(page: HtmlPage, d: dict[str, Any], units: dict[str, str]) -> None:
    """Add the numbers, the location and the parameters before and after the augmentation."""
    effect = d.get("effect")
    page.table(
        ["quantity", "value"],
        [
            ["mismatch", "yes"],
            ["effect", effect if effect is not None else "none"],
            ["chi2 before", d.get("chi2_before")],
            ["chi2 after", d.get("chi2_after")],
            ["likelihood-ratio p-value", _p(d.get("lrt_p_value"))],
            ["number of data", d.get("n_data")],
            ["family-wise false-alarm level", d.get("false_alarm")],
        ],
        table_id="diagnosis",
    )
    loc = d.get("location") or {}
    if loc:
        windows = "; ".join(interval(w) for w in loc.get("time_windows") or [])
        band = loc.get("frequency_hz")
        rows = [
            ["outputs", ", ".join(loc.get("outputs") or []) or "-"],
            ["experiments", ", ".join(loc.get("experiments") or []) or "-"],
            ["time windows [s]", windows or "-"],
            ["frequency band [Hz]", interval(band) if band else "-"],
        ]
        page.table(["where", "value"], rows, caption="Location of the mismatch")
    page.table(
        ["parameter", "unit", "before", "after"],
        [
            [n, units.get(n, "\u2014"), v.get("before"), v.get("after")]
            for n, v in d.get("parameters", {}).items()
        ],
        table_id="summary",
        caption="Free parameters before and after the augmentation",
    )


def _no_mismatch_summary(page: HtmlPage, d: dict[str, Any], units: dict[str, str]) -> None:
    """Add the fit's numbers and estimates: nothing was located or added."""
    page.table(
        ["quantity", "value"],
        [
            ["mismatch", "no"],
            ["chi2", d.get("chi2_before")],
            ["number of data", d.get("n_data")],
            ["family-wise false-alarm level", d.get("false_alarm")],
        ],
        table_id="diagnosis",
    )
    page.table(
        ["parameter", "unit", "estimate"],
        [[n, units.get(n, "\u2014"), v.get("before")] for n, v in d.get("parameters", {}).items()],
        table_id="summary",
        caption="Free parameters (the fit the tests were run on)",
    )


def _effects_and_validation(page: HtmlPage, d: dict[str, Any]) -> None:
    """Add each added effect's step, the held-out errors and where in the range the misfit sat."""
    steps = d.get("effects") or []
    if steps:
        page.table(
            ["step", "effect", "what it is", "chi2 before", "chi2 after", "p-value"],
            [
                [
                    k + 1,
                    s["effect"],
                    s["description"],
                    s["chi2_before"],
                    s["chi2_after"],
                    _p(s["p_value"]),
                ]
                for k, s in enumerate(steps)
            ],
            caption="Effects added one after another (forward selection)",
        )
    checked = d.get("validation") or []
    if checked:
        page.table(
            ["test file", "output", "samples", "RMS error, base", "after each step", "final"],
            [
                [
                    v["experiment"],
                    v["output"],
                    v["n"],
                    v["rms_base"],
                    ", ".join(f"{x:.4g}" for x in v["rms_by_step"]) or "-",
                    v["rms_final"],
                ]
                for v in checked
            ],
            caption="Held-out data: RMS of the simulation error (output units)",
        )
    levels = (d.get("location") or {}).get("levels") or {}
    words = [v["words"] for v in levels.values() if v.get("words")]
    if words:
        page.paragraph("Where in the range: " + "; ".join(words) + ".")


def _cost(page: HtmlPage, cost: dict[str, Any]) -> None:
    """Add the simulations and wall time of each step of the diagnosis, and their total."""
    stages = cost.get("stages") or []
    if not stages:
        return
    rows = [[s["stage"], int(s["simulations"]), duration(float(s["seconds"]))] for s in stages]
    rows.append(["total", int(cost["simulations"]), duration(float(cost["seconds"]))])
    page.table(["step", "simulations", "wall time"], rows, caption="What the diagnosis cost")


def _settling_test(page: HtmlPage, proposal: dict[str, Any] | None) -> None:
    """Add the test that would settle a tie, with both explanations' predictions under it."""
    if proposal:
        discrimination_section(page, discrimination_from_dict(proposal))


def _units(problem: Problem | None) -> dict[str, str]:
    """Units of the problem's variables and of every catalogue parameter that declares one."""
    if problem is None:
        return {}
    units = problem.units()
    start = {n: p.start for n, p in problem.parameter_specs.items()}
    for candidate in study_catalogue(problem, start):
        units.update({p.name: p.unit for p in candidate.parameters if p.unit})
    return units


def _whiteness(page: HtmlPage, d: dict[str, Any]) -> None:
    before = d.get("whiteness_before") or {}
    after = d.get("whiteness_after") or {}
    if not before:
        return
    if not d.get("added_parameters"):
        page.table(
            ["experiment / output", "Ljung-Box p"],
            [[k.replace("/", " / "), _p(v)] for k, v in before.items()],
            caption="Are the weighted residuals white? (small p: structure left in them)",
        )
        return
    page.table(
        ["experiment / output", "Ljung-Box p before", "Ljung-Box p after"],
        [[k.replace("/", " / "), _p(v), _p(after.get(k))] for k, v in before.items()],
        caption="Are the weighted residuals white? (small p: structure left in them)",
    )
