"""Trajectories over the parameter sets inside the simultaneous CI (thesis Figs 2.12, 3.5)."""

from __future__ import annotations

from matplotlib.figure import Figure

from fmuid.plots._common import DATA_COLOR, AxesArg, panels, unit_label
from fmuid.profiling.band import TrajectoryBand

BAND_COLOR = "tab:red"


def trajectory_band_figure(band: TrajectoryBand, *, ax: AxesArg = None) -> Figure:
    """Draw the outputs over parameter sets inside the simultaneous CI, with the data.

    One panel per experiment and fitted output against time: thin red lines for the parameter
    sets, the estimate in black and the data as blue dots. When the band holds planar paths
    (declared by the FMU, e.g. a vehicle's CG), one more panel per experiment draws them
    (y against x) the same way.

    Parameters
    ----------
    band
        The simulated band: ``fmuid.profiling.band.trajectory_band(problem, profile_result)``.
    ax
        Draw into these axes instead of a new figure: one per output panel, then one per path
        panel (``len(band.outputs) + len(band.paths)``). A new figure also gets a title that
        says what the colours mean.

    Returns
    -------
    Figure
        The panels described above (the figure holding ``ax`` when given).

    Raises
    ------
    ValueError
        If ``ax`` does not hold one axes per panel.

    """
    n = len(band.outputs) + len(band.paths)
    what = f"trajectory_band_figure: {len(band.outputs)} outputs + {len(band.paths)} path panels"
    fig, axes, new = panels(ax, n, what, ncols=2, panel_size=(6.0, 3.2))
    for panel, out in zip(axes, band.outputs, strict=False):
        for run in out.runs:
            panel.plot(out.time, run, color=BAND_COLOR, lw=0.8, alpha=0.35, gid="band")
        panel.plot(out.time, out.estimate, color="black", lw=1.6, gid="estimate")
        panel.plot(out.data_time, out.data, ".", color=DATA_COLOR, ms=4, gid="data")
        panel.set_title(f"{out.experiment}: {out.output}", fontsize=9)
        panel.set_xlabel("time [s]")
        panel.set_ylabel(unit_label(out.output, out.unit))
    for panel, paths in zip(axes[len(band.outputs) :], band.paths, strict=True):
        for m, (label, (x, y)) in enumerate(paths.estimate.items()):
            style = "-" if m == 0 else "--"
            for path in paths.runs:
                panel.plot(*path[label], color=BAND_COLOR, lw=0.8, alpha=0.35, ls=style, gid="band")
            panel.plot(x, y, color="black", lw=1.6, ls=style, label=label, gid="estimate")
        panel.set_title(f"{paths.experiment}: paths", fontsize=9)
        panel.set_xlabel(unit_label("x", paths.units[0]))
        panel.set_ylabel(unit_label("y", paths.units[1]))
        panel.legend(fontsize=7)
    if new:
        fig.suptitle(
            f"Trajectories over {band.n_sets} parameter sets inside the "
            f"{band.confidence:.0%} simultaneous CI\n(red), estimate (black), data (blue)",
            fontsize=10,
        )
    return fig
