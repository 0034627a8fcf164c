"""Experiment advice from profile studies of several designs at several noise levels.

One compact table per design: a row per parameter, a column per SNR level, each cell the
width of the simultaneous CI (decades for log-scaled parameters, relative width otherwise) or,
where the parameter is not identifiable, which ends are open and which parameters it trades
against along its profile. Slopes are left out where the profile is flat (it never rises to
the pointwise threshold on that side: the partners then wander freely) or where the profiled
parameter barely moved (a slope over a tiny step is noise).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from fmuid.estimation.space import value_to_z
from fmuid.profiling.result import IDENTIFIABLE, ParameterProfile, ProfileResult
from fmuid.report.page import Cell

MIN_SPAN = 0.05
"""Smallest move of the profiled parameter (decades, or relative) over which a slope is read."""
MIN_SLOPE = 0.1
"""Partners moving less than this (decades per decade) are left out."""
TIE = 0.01
"""Widths within this relative margin of the narrowest count as a tie: no design is marked."""
SHORT = {"practically_non_identifiable": "PNI", "structurally_non_identifiable": "SNI"}


@dataclass(frozen=True)
class StudyCase:
    """One profile study of the advice: its design, its noise level and the result."""

    design: str
    snr: float
    result: ProfileResult


@dataclass(frozen=True)
class AdviceTable:
    """The advice for one design.

    Attributes
    ----------
    design
        Design name.
    header
        Column names: parameter, one per SNR level, and how often the design was narrowest.
    rows
        One row of cells per parameter.

    """

    design: str
    header: tuple[str, ...]
    rows: tuple[tuple[Cell, ...], ...]


def log_width(prof: ParameterProfile) -> float:
    """Width of the simultaneous CI in decades (relative width for linear parameters).

    ``inf`` when an end is null (the profile never crossed the threshold on that side).
    """
    lo, hi = prof.ci_simultaneous
    if lo is None or hi is None:
        return math.inf
    if prof.scale == "log":
        return math.log10(hi / lo)
    return (hi - lo) / abs(prof.estimate) if prof.estimate else math.inf


def advice_tables(cases: Sequence[StudyCase]) -> list[AdviceTable]:
    """Build one table per design from the profile studies.

    A cell is marked ``good`` where its design gave the narrowest finite interval of every
    design at that SNR level (by more than :data:`TIE`), ``bad`` where the parameter is not
    identifiable.

    Parameters
    ----------
    cases
        The profile studies (every case profiles the same parameters).

    Returns
    -------
    list of AdviceTable
        In the order the designs first appear.

    """
    if not cases:
        return []
    snrs = sorted({c.snr for c in cases}, reverse=True)
    designs = list(dict.fromkeys(c.design for c in cases))
    names = list(cases[0].result.parameters)
    by_key = {(c.design, c.snr): c.result for c in cases}
    best = _narrowest(by_key, designs, snrs, names)
    tables = []
    for design in designs:
        rows = []
        for name in names:
            cells = [Cell(name)]
            for snr in snrs:
                result = by_key.get((design, snr))
                if result is None:
                    cells.append(Cell("not run"))
                    continue
                text, css = describe(result, name)
                if best.get((name, snr)) == design and len(designs) > 1:
                    css = "good"
                    text += " (narrowest)"
                cells.append(Cell(text, css))
            wins = sum(best.get((name, snr)) == design for snr in snrs)
            cells.append(Cell(f"{wins} of {len(snrs)}", "num"))
            rows.append(tuple(cells))
        header = ("parameter", *(f"SNR {s:g}" for s in snrs), "narrowest at")
        tables.append(AdviceTable(design, header, tuple(rows)))
    return tables


def study_verdict(cases: Sequence[StudyCase]) -> list[str]:
    """One line per design: how many parameters are identifiable at each SNR level."""
    lines = []
    for design in dict.fromkeys(c.design for c in cases):
        parts = []
        for c in sorted((c for c in cases if c.design == design), key=lambda c: -c.snr):
            params = c.result.parameters
            good = sum(p.status == IDENTIFIABLE for p in params.values())
            parts.append(f"{good} of {len(params)} at SNR {c.snr:g}")
        lines.append(f"{design}: identifiable {', '.join(parts)}.")
    return lines


def _narrowest(
    by_key: dict[tuple[str, float], ProfileResult],
    designs: list[str],
    snrs: list[float],
    names: list[str],
) -> dict[tuple[str, float], str]:
    out = {}
    for name in names:
        for snr in snrs:
            widths = {
                d: log_width(by_key[(d, snr)].parameters[name])
                for d in designs
                if (d, snr) in by_key
            }
            finite = sorted((w, d) for d, w in widths.items() if math.isfinite(w))
            tie = len(finite) > 1 and finite[1][0] <= finite[0][0] * (1 + TIE)
            if finite and not tie:
                out[(name, snr)] = finite[0][1]
    return out


def describe(result: ProfileResult, name: str) -> tuple[str, str]:
    """Return the cell text and CSS class of one parameter in one study."""
    prof = result.parameters[name]
    if prof.status == IDENTIFIABLE:
        width = log_width(prof)
        unit = "dec" if prof.scale == "log" else "rel."
        return f"{width:.2g} {unit}", ""
    sides = [s for s, end in zip(("lower", "upper"), prof.ci_simultaneous) if end is None]
    text = SHORT.get(prof.status, prof.status) + (
        f", open {' and '.join(sides)}" if sides else ", flat"
    )
    partners = trade_partners(result, name)
    if partners:
        text += "; trades with " + ", ".join(f"{n} ({s:+.2f})" for n, s in partners)
    return text, "bad"


def trade_partners(result: ProfileResult, name: str) -> list[tuple[str, float]]:
    """Parameters that move with ``name`` along its profile, with their slopes.

    The slope of another parameter is its change (decades for log-scaled, relative otherwise)
    between the estimate and the outermost point of an open side, divided by the profiled
    parameter's change; the largest over the sides is kept. A side gives no slope when the
    profile stays below the pointwise threshold there (flat) or moved less than
    :data:`MIN_SPAN`.

    Returns
    -------
    list of tuple
        ``(name, slope)``, largest magnitude first, those below :data:`MIN_SLOPE` left out.

    """
    prof = result.parameters[name]
    fit = result.fit
    scales = dict(zip(fit.names, fit.scales, strict=True))
    rise = result.thresholds.get("pointwise", 1.0)
    open_sides = [s for s, end in zip(("lower", "upper"), prof.ci_simultaneous) if end is None]
    slopes: dict[str, float] = {}
    for side in open_sides or ["lower", "upper"]:
        ok = [p for p in prof.points if p.error is None and math.isfinite(p.chi2)]
        points = [p for p in ok if (p.value < prof.estimate) == (side == "lower")]
        points = [p for p in points if p.value != prof.estimate]
        if not points or max(p.chi2 for p in points) - result.chi2 < rise:
            continue
        far = (min if side == "lower" else max)(points, key=lambda p: p.value)
        dz = _z(far.value, prof.scale, prof.estimate) - _z(prof.estimate, prof.scale, prof.estimate)
        if abs(dz) < MIN_SPAN:
            continue
        for other, v in far.params.items():
            if other in scales:
                ref = fit.estimates[other]
                slope = (_z(v, scales[other], ref) - _z(ref, scales[other], ref)) / dz
                if abs(slope) > abs(slopes.get(other, 0.0)):
                    slopes[other] = slope
    ranked = sorted(slopes.items(), key=lambda kv: -abs(kv[1]))
    return [(n, s) for n, s in ranked if abs(s) >= MIN_SLOPE]


def _z(value: float, scale: str, ref: float) -> float:
    """Fitted coordinate of a log-scaled value; a linear value relative to ``|ref|``."""
    return value_to_z(value / abs(ref) if scale == "lin" and ref else value, scale)
