"""Experiment advice from profile studies of several designs at several noise levels."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from fmuid.profile.result import IDENTIFIABLE, ParameterProfile, ProfileResult


@dataclass(frozen=True)
class StudyCase:
    """One profile study of the advice: its design, its noise level and the result."""

    design: str
    snr: float
    result: ProfileResult


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


def design_advice(cases: Sequence[StudyCase]) -> list[str]:
    """Say, per parameter, which design gives the narrowest interval at equal SNR.

    For each parameter and each SNR level tried with at least two designs, the design with the
    smallest simultaneous CI width in log space wins that level; the sentence names the design
    winning most levels, with the widths at the noisiest level where some design still gave a
    finite interval.

    Parameters
    ----------
    cases
        The profile studies.

    Returns
    -------
    list of str
        One sentence per parameter.

    """
    snrs = sorted({c.snr for c in cases}, reverse=True)
    designs = list(dict.fromkeys(c.design for c in cases))
    if len(designs) < 2:
        return ["Only one design was tried: no comparison of designs is possible."]
    names = list(cases[0].result.parameters)
    lines = []
    for name in names:
        wins: dict[str, int] = dict.fromkeys(designs, 0)
        levels = 0
        example = ""
        for snr in snrs:
            at = {c.design: log_width(c.result.parameters[name]) for c in cases if c.snr == snr}
            if len(at) < 2 or all(math.isinf(w) for w in at.values()):
                continue
            levels += 1
            best = min(at, key=lambda d: at[d])
            wins[best] += 1
            example = f"at SNR {snr:g}: " + ", ".join(
                f"{d} {_decades(w)}" for d, w in sorted(at.items(), key=lambda kv: kv[1])
            )
        if not levels:
            lines.append(f"{name}: no design gave a finite interval at any SNR level tried.")
            continue
        best = max(wins, key=lambda d: wins[d])
        lines.append(
            f"{name}: {best} narrows it most ({wins[best]} of {levels} SNR levels; {example})."
        )
    return lines


def _decades(width: float) -> str:
    return "unbounded" if math.isinf(width) else f"{width:.3g} decades"


@dataclass(frozen=True)
class FlatDirection:
    """What a non-identifiable parameter's profile shows.

    Attributes
    ----------
    design, snr, parameter, status
        Which study and parameter.
    open_sides
        ``"lower"`` and/or ``"upper"``: the sides where the CI has no end.
    partners
        Other parameters that move along the profile on an open side, with their slope in
        decades per decade of the profiled parameter (largest first).
    limited_by
        Parameters on a bound where the profile rose.

    """

    design: str
    snr: float
    parameter: str
    status: str
    open_sides: tuple[str, ...]
    partners: tuple[tuple[str, float], ...]
    limited_by: tuple[str, ...]

    def sentence(self) -> str:
        """Describe the flat direction in words."""
        sides = " and ".join(f"no {s} bound" for s in self.open_sides) or "flat profile"
        text = (
            f"{self.parameter} at {self.design}, SNR {self.snr:g}: "
            f"{self.status.replace('_', ' ')} ({sides})"
        )
        if self.partners:
            text += "; along its flat direction it trades against " + ", ".join(
                f"{n} ({s:+.2f} decades per decade)" for n, s in self.partners
            )
        else:
            text += "; the other parameters barely move: the data do not see it at all there"
        if self.limited_by:
            text += f"; the profile rises only where {', '.join(self.limited_by)} hit a bound"
        return text + "."


def flat_directions(cases: Sequence[StudyCase], min_slope: float = 0.1) -> list[FlatDirection]:
    """Read the flat direction of every parameter that is not identifiable off its profile.

    The slope of another parameter is its change (in fitted coordinates) between the estimate
    and the outermost point of the open side, divided by the profiled parameter's change.

    Parameters
    ----------
    cases
        The profile studies.
    min_slope
        Partners moving less than this (decades per decade) are left out.

    Returns
    -------
    list of FlatDirection
        In the order of the cases and their parameters.

    """
    out = []
    for case in cases:
        res = case.result
        scales = dict(zip(res.fit.names, res.fit.scales, strict=True))
        for name, prof in res.parameters.items():
            if prof.status == IDENTIFIABLE:
                continue
            sides = []
            if prof.ci_simultaneous[0] is None:
                sides.append("lower")
            if prof.ci_simultaneous[1] is None:
                sides.append("upper")
            slopes: dict[str, float] = {}
            for side in sides or ["lower", "upper"]:
                for other, slope in _slopes(prof, scales, res.fit.estimates, side).items():
                    if abs(slope) > abs(slopes.get(other, 0.0)):
                        slopes[other] = slope
            partners = tuple(
                (n, s)
                for n, s in sorted(slopes.items(), key=lambda kv: -abs(kv[1]))
                if abs(s) >= min_slope
            )
            out.append(
                FlatDirection(
                    case.design,
                    case.snr,
                    name,
                    prof.status,
                    tuple(sides),
                    partners,
                    prof.limited_by,
                )
            )
    return out


def _slopes(
    prof: ParameterProfile, scales: dict[str, str], estimates: dict[str, float], side: str
) -> dict[str, float]:
    ok = [p for p in prof.points if p.error is None and math.isfinite(p.chi2)]
    side_points = [
        p for p in ok if (p.value < prof.estimate if side == "lower" else p.value > prof.estimate)
    ]
    if not side_points:
        return {}
    far = (
        min(side_points, key=lambda p: p.value)
        if side == "lower"
        else max(side_points, key=lambda p: p.value)
    )
    dz = _z(far.value, prof.scale) - _z(prof.estimate, prof.scale)
    if dz == 0:
        return {}
    return {
        n: (_z(v, scales[n]) - _z(estimates[n], scales[n])) / dz
        for n, v in far.params.items()
        if n in scales
    }


def _z(value: float, scale: str) -> float:
    return math.log10(value) if scale == "log" else value
