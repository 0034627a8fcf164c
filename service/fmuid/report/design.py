"""Report pages of a design study and of a discrimination proposal.

Their figures are drawn by :mod:`fmuid.plots.design`.
"""

from __future__ import annotations

from pathlib import Path

from fmuid.experiment_design.discriminate import Discrimination
from fmuid.experiment_design.result import DesignResult
from fmuid.plots.design import discrimination_figure, widths_figure
from fmuid.readable import duration, interval
from fmuid.report.page import HtmlPage, fmt


def discrimination_section(page: HtmlPage, result: Discrimination) -> None:
    """Add the proposed test to a page: its settings, the expected separation, noise, figure."""
    a, b = result.hypotheses
    doc = result.to_dict()
    page.heading(f"The test that tells {a} from {b}")
    page.paragraph(
        f"Proposed: {result.trial.label}, driving {result.input_name}, measuring "
        f"{', '.join(result.trial.outputs)} ({result.screened} tests screened). Fitted to data "
        f"made by the other, the wrong hypothesis is expected to miss by chi2 = "
        f"{fmt(result.expected_chi2)} at the stated noise (a likelihood-ratio statistic of that "
        f"size has p = {fmt(doc['expected_p_value'], 2)})."
    )
    page.table(
        ["fit", "expected chi2 (noise-free data)"],
        [[name, value] for name, value in result.separation.items()],
        table_id="separation",
        caption="Weighted misfit of each hypothesis fitted to the other's prediction",
    )
    page.table(
        ["sensor", "noise sigma"],
        [[o, result.sigma.get(o)] for o in result.trial.outputs],
        table_id="noise",
        caption="Noise the separation is computed at (the unit of each output)",
    )
    page.figure(
        discrimination_figure(result),
        "discrimination",
        f"Input of the proposed test and both hypotheses' predictions under it ({a} with its "
        "noise band)",
    )


def write_discrimination_report(result: Discrimination, directory: Path) -> Path:
    """Write ``index.html`` of a discrimination proposal (:func:`discrimination_section`)."""
    a, b = result.hypotheses
    page = HtmlPage(Path(directory), f"Model discrimination: {a} versus {b}")
    discrimination_section(page, result)
    return page.write()


def write_design_report(result: DesignResult, directory: Path) -> Path:
    """Write ``index.html``: the ranked designs, the trade-offs and the widths figure."""
    page = HtmlPage(Path(directory), f"Experiment design: {result.model_name}")
    best = result.best
    page.paragraph(
        f"Recommended: {best.trial.label}, sensors {', '.join(best.trial.outputs)}; "
        f"{result.screened} designs screened by {result.criterion}-optimal Fisher information "
        f"in {duration(result.stage_seconds.get('screen_seconds', 0))}, the best verified by "
        f"profiles in {duration(result.stage_seconds.get('verify_seconds', 0))}."
    )
    for c in result.not_identifiable_by_any:
        page.paragraph(
            f"No experiment of the space identifies {', '.join(c['parameters'])}: {c['meaning']}.",
            note=True,
        )
    names = list(best.predicted)
    rows = []
    for rank, d in enumerate(result.designs, 1):
        cells: list[object] = [rank, d.trial.label, ", ".join(d.trial.outputs), d.score]
        for n in names:
            p = d.predicted[n]
            ver = f" ({d.verified.identifiable[n]}/{d.verified.draws})" if d.verified else ""
            cells.append(interval(p["ci"]) + ver)
        rows.append(cells)
    page.table(
        ["rank", "design", "sensors", "score", *names],
        rows,
        table_id="designs",
        caption="Predicted simultaneous CIs at the nominal; in brackets: draws whose profile "
        "found the parameter identifiable",
    )
    page.table(
        ["change to the recommended design", "score ratio", *names],
        [
            [
                k,
                v["score_ratio"] if v["score_ratio"] is not None else "singular",
                *(v["width"][n] if v["width"][n] is not None else v["status"][n] for n in names),
            ]
            for k, v in result.tradeoffs.items()
        ],
        table_id="tradeoffs",
        caption="Predicted CI widths [decades] after the change",
    )
    page.figure(widths_figure(result), "widths", "Predicted and verified CI widths")
    return page.write()
