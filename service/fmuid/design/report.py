"""Report page of a design study (its figures are in :mod:`fmuid.plots.design`)."""

from __future__ import annotations

from pathlib import Path

from fmuid.design.result import DesignResult
from fmuid.plots.design import widths_figure
from fmuid.report.page import HtmlPage, interval


def write_design_report(result: DesignResult, directory: Path) -> Path:
    """Write ``index.html``: the ranked designs, the trade-offs and the widths figure."""
    page = HtmlPage(Path(directory), f"Experiment design: {result.model_name}")
    best = result.best
    page.paragraph(
        f"Recommended: {best.trial.label}, sensors {', '.join(best.trial.outputs)}; "
        f"{result.screened} designs screened by {result.criterion}-optimal Fisher information "
        f"in {result.stage_seconds.get('screen_seconds', 0):.1f} s, the best verified by "
        f"profiles in {result.stage_seconds.get('verify_seconds', 0):.1f} s."
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
        ["rank", "design", "sensors", "score", *names], rows, table_id="designs",
        caption="Predicted simultaneous CIs at the nominal; in brackets: draws whose profile "
        "found the parameter identifiable",
    )  # fmt: skip
    page.table(
        ["change to the recommended design", "score ratio", *names],
        [
            [k, v["score_ratio"] if v["score_ratio"] is not None else "singular",
             *(v["width"][n] if v["width"][n] is not None else v["status"][n] for n in names)]
            for k, v in result.tradeoffs.items()
        ],
        table_id="tradeoffs", caption="Predicted CI widths [decades] after the change",
    )  # fmt: skip
    page.figure(widths_figure(result), "widths", "Predicted and verified CI widths")
    return page.write()
