"""Figures of an experiment design study and of a discrimination proposal."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from fmuid.experiment_design.discriminate import Discrimination
from fmuid.experiment_design.result import DesignResult
from fmuid.experiment_design.signals import input_signal
from fmuid.plots._common import AxesArg, panels, plain_log_ticks


def widths_figure(result: DesignResult, *, ax: AxesArg = None, top: int = 4) -> Figure:
    """Draw the predicted (Fisher) and verified (profile median) CI widths of the best designs.

    Parameters
    ----------
    result
        The design study (``fmuid.experiment_design.design``).
    ax
        Draw into this ``Axes`` (or a sequence holding one) instead of a new figure.
    top
        Number of best designs drawn (one bar group colour each).

    Returns
    -------
    Figure
        One panel: bars of the predicted simultaneous CI width [decades] per parameter and
        design, crosses at the verified median widths (the figure holding ``ax`` when given).

    Raises
    ------
    ValueError
        If ``ax`` holds more than one axes.

    """
    fig, (panel,), _ = panels(ax, 1, "widths_figure", ncols=1, panel_size=(8.0, 4.0))
    names = list(result.best.predicted)
    designs = result.designs[:top]
    width = 0.8 / max(len(designs), 1)
    x = np.arange(len(names))
    for k, d in enumerate(designs):
        pred = [d.predicted[n].get("width_z", np.nan) for n in names]
        panel.bar(
            x + k * width,
            pred,
            width,
            label=f"#{k + 1} {d.trial.family}, {d.trial.rate_hz:g} Hz, "
            f"{len(d.trial.outputs)} sensors",
            gid="predicted",
        )
        if d.verified is not None:
            ver = [d.verified.median_width(n) for n in names]
            panel.plot(x + k * width, ver, "x", color="black", gid="verified")
    panel.set_xticks(x + 0.4 - width / 2, names)
    panel.set_yscale("log")
    plain_log_ticks(panel.yaxis)
    panel.set_ylabel("simultaneous CI width [decades]")
    panel.set_title("bars: Fisher prediction, x: profile median")
    panel.legend(fontsize="small")
    return fig


def discrimination_figure(result: Discrimination, *, ax: AxesArg = None) -> Figure:
    """Draw the proposed test's input and both hypotheses' noise-free predictions.

    Parameters
    ----------
    result
        The proposal (``fmuid.experiment_design.discriminate``); its predictions were simulated
        there.
    ax
        Draw into these axes instead of a new figure: one for the input, then one per sensor
        output of the proposed test (``1 + len(result.trial.outputs)``).

    Returns
    -------
    Figure
        The input panel over one panel per output, each with one line per hypothesis and the
        first hypothesis' noise band (+- the sensor's sigma, when known) (the figure holding
        ``ax`` when given; a new figure shares the time axis).

    Raises
    ------
    ValueError
        If ``ax`` does not hold ``1 + len(result.trial.outputs)`` axes.

    """
    outputs = list(result.trial.outputs)
    what = f"discrimination_figure: the input and {len(outputs)} outputs"
    fig, axes, new = panels(ax, len(outputs) + 1, what, ncols=1, panel_size=(8.0, 2.2))
    if new:
        for a in axes[1:]:
            a.sharex(axes[0])
    t_in, u = input_signal(result.trial)
    axes[0].plot(t_in, u, "k-", gid="input")
    axes[0].set_ylabel(result.input_name)
    axes[0].set_title(f"{result.trial.label}: expected chi2 separation {result.expected_chi2:.3g}")
    for a, o in zip(axes[1:], outputs, strict=True):
        for k, (name, pred) in enumerate(result.predictions.items()):
            (line,) = a.plot(result.time, pred[o], label=name, gid=f"prediction_{name}")
            if k == 0 and o in result.sigma:
                band = (pred[o] - result.sigma[o], pred[o] + result.sigma[o])
                a.fill_between(
                    result.time,
                    *band,
                    color=line.get_color(),
                    alpha=0.2,
                    lw=0,
                    label=f"{name} \u00b1 noise sigma",
                    gid="noise_band",
                )
        a.set_ylabel(o)
        a.legend(fontsize="small")
    axes[-1].set_xlabel("time [s]")
    return fig
