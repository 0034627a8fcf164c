"""The verdict that opens a profile report, and the profile-quality record in words."""

from __future__ import annotations

from fmuid.profiling.intervals import NOISE_PREFIX
from fmuid.profiling.result import IDENTIFIABLE, ParameterProfile, ProfileQuality, ProfileResult

_QUALITY_WORDS = (
    ("checks", "valley check", "valley checks"),
    ("starts", "start", "starts"),
    ("jumps", "jump", "jumps"),
    ("lower_valleys", "lower valley", "lower valleys"),
    ("rewalks", "re-walk", "re-walks"),
    ("end_refits", "end re-fit", "end re-fits"),
)


def quality_text(quality: ProfileQuality) -> str:
    """Say how a profile was checked, e.g. ``settled; 2 valley checks (12 starts), 1 jump``."""
    counts = [
        f"{n} {one if n == 1 else many}"
        for key, one, many in _QUALITY_WORDS
        if (n := int(getattr(quality, key)))
    ]
    head = "not settled: " + "; ".join(quality.unsettled) if quality.unsettled else "settled"
    return head + (f" ({', '.join(counts)})" if counts else "")


def _open_ends(p: ParameterProfile) -> str:
    lo, hi = p.ci_simultaneous
    ends = [side for side, end in (("lower", lo), ("upper", hi)) if end is None]
    if ends:
        return f"no {' and no '.join(ends)} end"
    if p.status_reason.startswith(NOISE_PREFIX):
        return "ends the FMU's solver noise could move"
    return "flat profile"


def profile_verdict(result: ProfileResult) -> list[str]:
    """Return the opening lines of a profile report: which parameters the data pin down.

    Returns
    -------
    list of str
        A count line, one line per non-identifiable group, and warnings (better optimum,
        unsettled profiles).

    """
    params = result.parameters
    good = [n for n, p in params.items() if p.status == IDENTIFIABLE]
    level = f"{result.confidence:.0%}"
    lines = [
        f"{len(good)} of {len(params)} parameters are identifiable from these data "
        f"(finite {level} simultaneous likelihood-based intervals)"
        + (f": {', '.join(good)}." if good else ".")
    ]
    for status in ("practically_non_identifiable", "structurally_non_identifiable"):
        names = [n for n, p in params.items() if p.status == status]
        if names:
            detail = ", ".join(f"{n} ({_open_ends(params[n])})" for n in names)
            lines.append(f"{status.replace('_', ' ').capitalize()}: {detail}.")
    for combo in result.structural_check.get("non_identifiable_combinations", []):
        if combo.get("meaning"):
            lines.append(f"Structural check: {combo['meaning']}.")
    unsettled = [n for n, p in params.items() if p.quality.unsettled]
    if unsettled:
        lines.append(f"Not settled by the checks (read with care): {', '.join(unsettled)}.")
    if result.better_optimum_found:
        lines.append("Profiling found a better optimum than the fit; the profiles start from it.")
    return lines
