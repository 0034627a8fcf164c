"""Profile-likelihood figures: the profiles (thesis Fig 2.8/3.3) and parameter paths (Fig 2.9)."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from fmuid.plots._common import (
    BOUND_COLOR,
    ESTIMATE_COLOR,
    PROFILE_COLOR,
    QUADRATIC_COLOR,
    THRESHOLD_COLOR,
    AxesArg,
    axis_label,
    panels,
    to_plot_coordinate,
)
from fmuid.profiling.result import ParameterProfile, ProfileResult


def profile_figure(
    result: ProfileResult, name: str | None = None, *, ax: AxesArg = None, ncols: int = 3
) -> Figure:
    """Draw the profile likelihood of every free parameter (one panel each), or of one.

    Each panel shows, against the parameter in fitted coordinates (log10 for log-scaled
    parameters): the profile chi2 (black), its quadratic approximation
    ``chi2_opt + ((z - z_hat) / sd_z)**2`` from the Fisher information (gray; not for a result
    read back with ``load_result``, which holds no Jacobian), the pointwise and simultaneous
    thresholds ``chi2_opt + threshold`` (red dashed), the estimate (gray asterisk), points where
    another parameter sat on a bound (red dots) and points whose re-fit failed (black crosses).

    Parameters
    ----------
    result
        The profile study.
    name
        Draw only this parameter's profile (default: every parameter).
    ax
        Draw into these axes instead of a new figure: one ``Axes`` for one parameter's profile
        (``name`` given), or a sequence of them, one per parameter in ``result.parameters``
        order.
    ncols
        Panels per row of a new figure.

    Returns
    -------
    Figure
        The figure drawn on (the one holding ``ax`` when given).

    Raises
    ------
    KeyError
        If ``name`` was not profiled.
    ValueError
        If ``ax`` does not hold one axes per drawn profile.

    """
    names = [name] if name is not None else list(result.parameters)
    for n in names:
        if n not in result.parameters:
            raise KeyError(f"{n!r} was not profiled; profiled: {', '.join(result.parameters)}")
    what = f"profile_figure: one per profile, {', '.join(names)}"
    fig, axes, new = panels(ax, len(names), what, ncols=ncols)
    if new:
        fig.suptitle(f"Profile likelihoods ({result.confidence:.0%} confidence)")
    fisher = result.fit.fisher_sd_z()
    for panel, n in zip(axes, names, strict=True):
        prof = result.parameters[n]
        sd = prof.fisher_sd_z if math.isfinite(prof.fisher_sd_z) else fisher.get(n, math.inf)
        unit = result.fit.units.get(n, "")
        _draw_profile(panel, prof, result.chi2, result.thresholds, sd, unit)
    return fig


def _draw_profile(
    ax: Axes,
    prof: ParameterProfile,
    chi2_opt: float,
    thresholds: dict[str, float],
    sd_z: float,
    unit: str,
) -> None:
    ok = [p for p in prof.points if p.error is None and math.isfinite(p.chi2)]
    failed = [p for p in prof.points if p.error is not None or not math.isfinite(p.chi2)]
    x = np.array([to_plot_coordinate(p.value, prof.scale) for p in ok])
    y = np.array([p.chi2 for p in ok])
    z_hat = to_plot_coordinate(prof.estimate, prof.scale)
    lo = to_plot_coordinate(prof.lower, prof.scale)
    hi = to_plot_coordinate(prof.upper, prof.scale)
    span = np.array([x.min(), x.max()]) if x.size else np.array([lo, hi])
    ax.plot(x, y, color=PROFILE_COLOR, lw=1.5, label="profile", gid="profile")
    if math.isfinite(sd_z) and sd_z > 0:
        xq = np.linspace(span[0], span[1], 200)
        ax.plot(
            xq,
            chi2_opt + ((xq - z_hat) / sd_z) ** 2,
            color=QUADRATIC_COLOR,
            lw=1.0,
            label="quadratic approximation",
            gid="quadratic",
        )
    for kind in ("pointwise", "simultaneous"):
        if kind in thresholds:
            ax.axhline(
                chi2_opt + thresholds[kind],
                color=THRESHOLD_COLOR,
                ls="--",
                lw=1.0,
                label=f"{kind} threshold",
                gid=f"threshold_{kind}",
            )
    bound = [(xi, yi) for xi, yi, p in zip(x, y, ok, strict=True) if p.at_bound]
    if bound:
        bx, by = zip(*bound, strict=True)
        ax.plot(
            bx, by, "o", color=BOUND_COLOR, ms=4, ls="none", label="other on bound", gid="at_bound"
        )
    ax.plot(
        [z_hat],
        [chi2_opt],
        "*",
        color=ESTIMATE_COLOR,
        ms=11,
        ls="none",
        label="estimate",
        gid="estimate",
    )
    if failed:
        fx = [to_plot_coordinate(p.value, prof.scale) for p in failed]
        ax.plot(
            fx,
            [0.03] * len(fx),
            "x",
            color="black",
            ms=6,
            ls="none",
            transform=ax.get_xaxis_transform(),
            label="failed point",
            gid="failed",
        )
    top = chi2_opt + 2.0 * thresholds.get("simultaneous", 1.0)
    if y.size and np.nanmax(y) < top:
        top = float(np.nanmax(y)) + 0.1 * (top - chi2_opt)
    ax.set_ylim(chi2_opt - 0.1 * (top - chi2_opt), top)
    ax.set_xlabel(axis_label(prof.name, prof.scale, unit))
    ax.set_ylabel("chi2")
    ax.set_title(f"{prof.name}: {prof.status.replace('_', ' ')}", fontsize=9)


def parameter_paths_figure(result: ProfileResult, name: str, *, ax: AxesArg = None) -> Figure:
    """Draw how the other free parameters move along the profile of ``name`` (thesis Fig 2.9).

    Every parameter is shown as its change from the estimate in fitted coordinates (decades for
    log-scaled parameters), against the profiled parameter in fitted coordinates. A parameter
    that trades against the profiled one (e.g. ``k1 + k2`` constant) shows as a sloped line;
    points where it sat on a bound are red. The simultaneous confidence interval is shaded.

    Parameters
    ----------
    result
        The profile study.
    name
        The profiled parameter.
    ax
        Draw into this ``Axes`` (or a sequence holding one) instead of a new figure.

    Returns
    -------
    Figure
        One panel (the figure holding ``ax`` when given); one line per other free parameter,
        labelled with its name.

    Raises
    ------
    KeyError
        If ``name`` was not profiled.
    ValueError
        If ``ax`` holds more than one axes.

    """
    prof = result.parameters[name]
    fit = result.fit
    others = [n for n in fit.names if n != name]
    scales = dict(zip(fit.names, fit.scales, strict=True))
    ok = [p for p in prof.points if p.error is None]
    x = np.array([to_plot_coordinate(p.value, prof.scale) for p in ok])
    fig, (panel,), _ = panels(ax, 1, "parameter_paths_figure", ncols=1, panel_size=(8.0, 4.5))
    for other in others:
        ref = to_plot_coordinate(fit.estimates[other], scales[other])
        y = np.array(
            [to_plot_coordinate(p.params.get(other, math.nan), scales[other]) - ref for p in ok]
        )
        (line,) = panel.plot(x, y, marker=".", lw=1.2, label=other, gid=f"path_{other}")
        on_bound = [i for i, p in enumerate(ok) if other in p.at_bound]
        if on_bound:
            panel.plot(x[on_bound], y[on_bound], "o", color=BOUND_COLOR, ms=4, ls="none")
    lo, hi = prof.ci_simultaneous
    x_lo = to_plot_coordinate(lo, prof.scale) if lo is not None else (x.min() if x.size else 0.0)
    x_hi = to_plot_coordinate(hi, prof.scale) if hi is not None else (x.max() if x.size else 0.0)
    panel.axvspan(x_lo, x_hi, color="0.9", zorder=0, label="simultaneous CI")
    panel.axvline(to_plot_coordinate(prof.estimate, prof.scale), color=ESTIMATE_COLOR, ls=":", lw=1)
    panel.set_xlabel(axis_label(name, prof.scale, result.fit.units.get(name, "")))
    panel.set_ylabel("change from estimate\n(decades if log-scaled, else own unit)")
    panel.set_title(f"Parameters along the profile of {name}")
    if others:
        panel.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=9)
    return fig
