"""Trajectories over the parameter sets inside the simultaneous CI (thesis Figs 2.12, 3.5)."""

from __future__ import annotations

from matplotlib.figure import Figure

from fmuid.plots._common import DATA_COLOR, new_figure, unit_label
from fmuid.profile.band import TrajectoryBand

BAND_COLOR = "tab:red"


def trajectory_band_figure(band: TrajectoryBand) -> Figure:
    """Draw the outputs over parameter sets inside the simultaneous CI, with the data.

    One panel per experiment and fitted output against time: thin red lines for the parameter
    sets, the estimate in black and the data as blue dots. When the band holds CG paths, one
    more panel per experiment draws the tractor and implement paths (y against x) the same way.

    Parameters
    ----------
    band
        The simulated band: ``fmuid.profile.band.trajectory_band(problem, profile_result)``.

    Returns
    -------
    Figure
        The panels described above.

    """
    fig, axes = new_figure(len(band.outputs) + len(band.paths), ncols=2, panel_size=(6.0, 3.2))
    for ax, out in zip(axes, band.outputs, strict=False):
        for run in out.runs:
            ax.plot(out.time, run, color=BAND_COLOR, lw=0.8, alpha=0.35, gid="band")
        ax.plot(out.time, out.estimate, color="black", lw=1.6, gid="estimate")
        ax.plot(out.data_time, out.data, ".", color=DATA_COLOR, ms=4, gid="data")
        ax.set_title(f"{out.experiment}: {out.output}", fontsize=9)
        ax.set_xlabel("time [s]")
        ax.set_ylabel(unit_label(out.output, out.unit))
    for ax, paths in zip(axes[len(band.outputs) :], band.paths, strict=True):
        for m, (label, (x, y)) in enumerate(paths.estimate.items()):
            style = "-" if m == 0 else "--"
            for path in paths.runs:
                ax.plot(*path[label], color=BAND_COLOR, lw=0.8, alpha=0.35, ls=style, gid="band")
            ax.plot(x, y, color="black", lw=1.6, ls=style, label=label, gid="estimate")
        ax.set_title(f"{paths.experiment}: CG paths", fontsize=9)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.legend(fontsize=7)
    fig.suptitle(
        f"Trajectories over {band.n_sets} parameter sets inside the "
        f"{band.confidence:.0%} simultaneous CI\n(red), estimate (black), data (blue)",
        fontsize=10,
    )
    return fig
