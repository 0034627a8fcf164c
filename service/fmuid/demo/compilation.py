"""Compilation of confidence intervals across datasets and designs (thesis Figs 3.4, 3.9, 3.10)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from matplotlib.axes import Axes
from matplotlib.figure import Figure

from fmuid.plots._common import AxesArg, panels, plain_log_ticks
from fmuid.profiling.result import ProfileResult

BAR_COLOR = "tab:red"
ESTIMATE_MARKER_COLOR = "tab:green"


@dataclass(frozen=True)
class CiEntry:
    """One confidence-interval bar of a compilation figure.

    Attributes
    ----------
    parameter
        Parameter name; one panel per parameter.
    label
        Text left of the bar, e.g. ``"SNR 1000"``.
    estimate
        Best-fit value (parameter units).
    ci
        Interval ends (parameter units); ``None`` for an end the profile never crossed.
    lower, upper
        The parameter's bounds: a bar with a ``None`` end runs to the bound and ends in an arrow.
    scale
        ``"log"`` (logarithmic axis) or ``"lin"``.
    group
        Bars of one group (e.g. one experiment design) are drawn together under a heading.
    true
        The value that made the data, when known (black line).
    unit
        The parameter's unit, shown in the panel title.

    """

    parameter: str
    label: str
    estimate: float
    ci: tuple[float | None, float | None]
    lower: float
    upper: float
    scale: str = "log"
    group: str = ""
    true: float | None = None
    unit: str = ""


def ci_entries_from_profile(
    result: ProfileResult,
    label: str,
    *,
    group: str = "",
    true_values: Mapping[str, float] | None = None,
    kind: str = "simultaneous",
) -> list[CiEntry]:
    """Turn a profile study into compilation entries, one per parameter.

    Parameters
    ----------
    result
        The profile study.
    label
        Text left of each bar, e.g. ``"SNR 25"``.
    group
        Group (design) of the bars.
    true_values
        Values that made the data, by parameter name.
    kind
        ``"simultaneous"`` or ``"pointwise"`` interval.

    Returns
    -------
    list of CiEntry
        In the order of ``result.parameters``.

    """
    truth = dict(true_values or {})
    return [
        CiEntry(
            parameter=name,
            label=label,
            estimate=p.estimate,
            ci=p.ci_simultaneous if kind == "simultaneous" else p.ci_pointwise,
            lower=p.lower,
            upper=p.upper,
            scale=p.scale,
            group=group,
            true=truth.get(name),
            unit=result.fit.units.get(name, ""),
        )
        for name, p in result.parameters.items()
    ]


def ci_compilation_figure(
    entries: Sequence[CiEntry],
    *,
    ax: AxesArg = None,
    ncols: int = 3,
    title: str | None = None,
) -> Figure:
    """Draw confidence-interval bars of many studies, one panel per parameter.

    In each panel the bars run horizontally (one row per entry, grouped by ``group`` with the
    group name as a heading), red bars span the interval, an end that is ``None`` runs to the
    parameter's bound and carries an arrow, a green diamond marks the estimate and a black
    vertical line the true value when known. Log-scaled parameters use a logarithmic axis in
    parameter units (normal space, as thesis Figs 3.9/3.10).

    Parameters
    ----------
    entries
        The bars, in drawing order (top to bottom within a group).
    ax
        Draw into these axes instead of a new figure: one per distinct ``parameter``, in order
        of first appearance.
    ncols
        Panels per row of a new figure.
    title
        Figure title (set on the figure holding ``ax`` too when given).

    Returns
    -------
    Figure
        One panel per distinct ``parameter`` in ``entries``, in order of first appearance (the
        figure holding ``ax`` when given).

    Raises
    ------
    ValueError
        If ``ax`` does not hold one axes per parameter.

    """
    params = list(dict.fromkeys(e.parameter for e in entries))
    what = f"ci_compilation_figure: one per parameter, {', '.join(params) or 'none'}"
    size = (4.2, 0.35 * _rows(entries) + 1.2)
    fig, axes, _ = panels(ax, len(params), what, ncols=ncols, panel_size=size)
    for panel, name in zip(axes, params, strict=True):
        bars = [e for e in entries if e.parameter == name]
        _draw_panel(panel, bars)
        panel.set_title(f"{name} [{bars[0].unit}]" if bars[0].unit else name)
    if title:
        fig.suptitle(title)
    return fig


def _rows(entries: Sequence[CiEntry]) -> int:
    per_param: dict[str, set[str]] = {}
    groups: dict[str, set[str]] = {}
    for e in entries:
        per_param.setdefault(e.parameter, set()).add(f"{e.group}\0{e.label}")
        groups.setdefault(e.parameter, set()).add(e.group)
    return max((len(v) + len(groups[k]) for k, v in per_param.items()), default=1)


def _draw_panel(ax: Axes, entries: Sequence[CiEntry]) -> None:
    y = 0.0
    ticks: list[float] = []
    labels: list[str] = []
    spans: dict[str, list[float]] = {}
    truth: dict[str, float] = {}
    for e in entries:
        if e.group not in spans:
            if e.group:
                ax.text(
                    0.01,
                    y,
                    e.group,
                    transform=ax.get_yaxis_transform(),
                    fontsize=8,
                    fontweight="bold",
                    va="center",
                )
                y -= 1.0
            spans[e.group] = []
        spans[e.group].append(y)
        if e.true is not None:
            truth.setdefault(e.group, e.true)
        lo = e.ci[0] if e.ci[0] is not None else e.lower
        hi = e.ci[1] if e.ci[1] is not None else e.upper
        ax.plot([lo, hi], [y, y], color=BAR_COLOR, lw=5, solid_capstyle="butt", gid="ci_bar")
        if e.ci[0] is None:
            _arrow(ax, lo, y, left=True)
        if e.ci[1] is None:
            _arrow(ax, hi, y, left=False)
        ax.plot(
            [e.estimate],
            [y],
            "D",
            color=ESTIMATE_MARKER_COLOR,
            mec="black",
            ms=6,
            ls="none",
            gid="estimate",
        )
        ticks.append(y)
        labels.append(e.label)
        y -= 1.0
    for group, value in truth.items():
        rows = spans[group]
        ax.plot(
            [value, value],
            [min(rows) - 0.5, max(rows) + 0.5],
            color="black",
            lw=1.5,
            gid="true_value",
        )
    if entries and entries[0].scale == "log":
        ax.set_xscale("log")
        plain_log_ticks(ax.xaxis)
    if entries:
        lo, hi = min(e.lower for e in entries), max(e.upper for e in entries)
        if entries[0].scale == "log":
            pad = (hi / lo) ** 0.04
            ax.set_xlim(lo / pad, hi * pad)
        else:
            ax.set_xlim(lo - 0.04 * (hi - lo), hi + 0.04 * (hi - lo))
    ax.set_yticks(ticks, labels, fontsize=8)
    ax.set_ylim(y + 0.5, 0.5)


def _arrow(ax: Axes, x: float, y: float, *, left: bool) -> None:
    """Draw an outward arrow head at a bar end that is a parameter bound (a null CI end)."""
    ax.annotate(
        "",
        xy=(x, y),
        xytext=(14 if left else -14, 0),
        textcoords="offset points",
        arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.5, "mutation_scale": 14},
        annotation_clip=False,
    )
