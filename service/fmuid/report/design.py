"""Report page and figures of a design study and of a discrimination proposal."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from fmuid.design.discriminate import Discrimination
from fmuid.design.result import DesignResult
from fmuid.design.signals import input_signal
from fmuid.report.page import HtmlPage, fmt, interval


def widths_figure(result: DesignResult, ax: Axes | None = None, top: int = 4) -> Figure:
    """Predicted (Fisher) and verified (profile median) interval widths of the best designs."""
    fig: Any
    if ax is None:
        fig = Figure(figsize=(8, 4), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    names = list(result.best.predicted)
    designs = result.designs[:top]
    width = 0.8 / max(len(designs), 1)
    x = np.arange(len(names))
    for k, d in enumerate(designs):
        pred = [d.predicted[n].get("width_z", np.nan) for n in names]
        ax.bar(
            x + k * width,
            pred,
            width,
            label=f"#{k + 1} {d.trial.family}, {d.trial.rate_hz:g} Hz, "
            f"{len(d.trial.outputs)} sensors",
        )
        if d.verified is not None:
            ver = [d.verified.median_width(n) for n in names]
            ax.plot(x + k * width, ver, "x", color="black")
    ax.set_xticks(x + 0.4 - width / 2, names)
    ax.set_yscale("log")
    ax.set_ylabel("simultaneous CI width [decades]")
    ax.set_title("bars: Fisher prediction, x: profile median")
    ax.legend(fontsize="small")
    return fig


def discrimination_figure(result: Discrimination, ax: Axes | None = None) -> Figure:
    """Plot the proposed test's input and both hypotheses' noise-free predictions."""
    outputs = list(result.trial.outputs)
    fig = Figure(figsize=(8, 2.2 * (len(outputs) + 1)), layout="constrained")
    axes = fig.subplots(len(outputs) + 1, 1, sharex=True)
    t_in, u = input_signal(result.trial)
    axes[0].plot(t_in, u, "k-")
    axes[0].set_ylabel(result.input_name)
    axes[0].set_title(f"{result.trial.label}: expected chi2 separation {result.expected_chi2:.3g}")
    for a, o in zip(axes[1:], outputs, strict=True):
        for k, (name, pred) in enumerate(result.predictions.items()):
            line = a.plot(result.time, pred[o], label=name)[0]
            if k == 0 and o in result.sigma:
                band = (pred[o] - result.sigma[o], pred[o] + result.sigma[o])
                a.fill_between(result.time, *band, color=line.get_color(), alpha=0.2, lw=0,
                               label=f"{name} \u00b1 noise sigma")  # fmt: skip
        a.set_ylabel(o)
        a.legend(fontsize="small")
    axes[-1].set_xlabel("time [s]")
    return fig


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
