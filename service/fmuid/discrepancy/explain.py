"""Explain: the sentences of a diagnosis, worded by the statistics behind them."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from scipy import stats

from fmuid.discrepancy.decide import Tie, strength
from fmuid.discrepancy.residual_tests import TestResult
from fmuid.discrepancy.result import AddedEstimate, EffectStep
from fmuid.discrepancy.settle import settles
from fmuid.experiment_design.discriminate import Discrimination
from fmuid.readable import p_text

if TYPE_CHECKING:
    from fmuid.estimation.validation import ValidationEntry


def _fmt_ci(e: AddedEstimate) -> str:
    lo = "-inf" if e.ci[0] is None else f"{e.ci[0]:.3g}"
    hi = "inf" if e.ci[1] is None else f"{e.ci[1]:.3g}"
    verdict = "excludes" if e.excludes_off else "does not exclude"
    return f"{e.confidence:.0%} CI [{lo}, {hi}] {verdict} the off value {e.off:g}"


def no_mismatch(alpha: float, scan_p: float | None) -> str:
    """Verdict when no test of the family rejects."""
    scan = "" if scan_p is None else f" (best candidate, adjusted for the scan: {p_text(scan_p)})"
    return (
        "No mismatch: neither the residual tests, nor the agreement of the experiments, nor the "
        f"generic input-driven error model, nor any candidate of the catalogue{scan} rejects the "
        f"model at a family-wise false-alarm level of {alpha:g}."
    )


def explained(
    steps: Sequence[EffectStep],
    chi2_before: float,
    chi2_after: float,
    lrt: float,
    ties: Sequence[Tie],
    concealed: bool,
    rival: Mapping[str, Any] | None = None,
    residuals_pass: bool = True,
) -> str:
    """Verdict and summary of the named effects, step by step.

    ``rival``: the generic error model as a tie; ``residuals_pass``: whether the final model's
    residuals pass every test (else the remaining misfit is said to be there).
    """
    parts = []
    for k, step in enumerate(steps):
        first = step.parameters[next(iter(step.parameters))]
        name = next(iter(step.parameters))
        drop = step.chi2_before - step.chi2_after
        lead = "" if len(steps) == 1 else f"step {k + 1}, "
        coupling = step.coupling_error
        rough = (
            f"; halving the co-simulation step moves the fit by {coupling:.2g} sigma: the term "
            "is not resolved at this step"
            if coupling is not None and coupling > 1.0
            else ""
        )
        parts.append(
            f"{lead}{step.effect}: {step.description} ({name} {_fmt_ci(first)}; chi2 drop "
            f"{drop:.4g}, {p_text(step.p_value)}{rough})"
        )
    out = "; ".join(parts)
    out = out[0].upper() + out[1:]
    tail = (
        "the augmented model's residuals pass every test"
        if residuals_pass
        else "the augmented model's residuals still fail a test: part of the misfit is left "
        "(see generic_correction)"
    )
    out += f". Chi2 {chi2_before:.4g} -> {chi2_after:.4g}: {strength(lrt)} from the " + (
        f"likelihood-ratio test; {tail}."
    )
    if concealed:
        out += (
            " The base model's residuals looked like noise: the fit had moved its parameters to "
            "hide the effect."
        )
    if ties:
        names = ", ".join(_tie(t, ties) for t in ties)
        out += f" Equally good explanations that this data cannot tell apart: {names}."
    if rival:
        out += (
            f" An input-driven error model outside the catalogue ({rival['model']}) explains "
            f"the data as well (Vuong {p_text(rival['p_value'])}): the named effect may stand in "
            "for physics that the catalogue lacks."
        )
    return out


MISFIT_SCALE = 2.0
"""Chi2 per degree of freedom of a final model from which the verdict says its intervals are
narrower than its misfit warrants (residuals about 1.4 times the stated noise and more)."""


def misfit_scale(chi2: float, dof: int, residuals_pass: bool) -> str:
    """Sentence on a final model whose misfit is well above the stated noise, else ''."""
    per_dof = chi2 / max(dof, 1)
    if residuals_pass or per_dof < MISFIT_SCALE:
        return ""
    return (
        f" The final model leaves chi2 {per_dof:.3g} per degree of freedom: its residuals are "
        f"about {math.sqrt(per_dof):.2g} times the stated noise, and the intervals, which take the "
        "sigmas for the whole error, are narrower than that misfit warrants (scaled by it, "
        f"{math.sqrt(per_dof):.2g} times wider)."
    )


def held_out(entries: Sequence[ValidationEntry]) -> str:
    """Sentence on the held-out data: RMS simulation error before and after."""
    parts = [f"{e.output} in {e.experiment} {e.rms_base:.3g} -> {e.rms_final:.3g}" for e in entries]
    if not parts:
        return ""
    return f" Held-out data, RMS simulation error (output units): {'; '.join(parts)}."


def levels(found: Mapping[str, Any]) -> str:
    """Sentence on where in the outputs' range the base fit's misfit sat."""
    words = [v["words"] for v in found.values() if v.get("words")]
    return f" Before the augmentation, {'; '.join(words)}." if words else ""


def _tie(t: Tie, ties: Sequence[Tie]) -> str:
    """Return a tie's effect and test, with its parameter when another tie has the same effect."""
    c = t.fit.candidate
    test = "equal predictions" if t.test == "equal_predictions" else f"Vuong {p_text(t.p_value)}"
    same = sum(u.fit.candidate.effect == c.effect for u in ties)
    return f"{c.effect} ({c.parameters[0].name}; {test})" if same > 1 else f"{c.effect} ({test})"


def settle(tests: Sequence[Discrimination]) -> str:
    """Sentences on the tests that would settle the ties, or on why none in reach can."""
    out = ""
    for found in tests:
        a, b = found.hypotheses
        lam = found.expected_chi2
        if settles(found):
            out += (
                f" A test would tell {a} from {b}: {found.trial.label}, measuring "
                f"{', '.join(found.trial.outputs)}, separates them by an expected chi2 of "
                f"{lam:.3g} ({strength(float(stats.chi2.sf(lam, 1)))} expected)."
            )
        else:
            out += (
                f" No step, chirp or multisine like this data's (its input amplitude, length, "
                f"rate and outputs) tells {a} from {b}: the largest expected chi2 separation "
                f"is {lam:.3g}{'' if found.confirmed else ' (linearised)'}."
            )
    return out


def unexplained(
    best: Any, worst: TestResult | None, correction: dict[str, Any], where: dict[str, Any]
) -> str:
    """Verdict when no catalogue entry removes a mismatch."""
    outputs = where.get("outputs")
    place = ", ".join(map(str, outputs)) if isinstance(outputs, list) and outputs else "the outputs"
    out = f"Mismatch in {place} that no catalogue entry removes"
    if best is not None:
        out += f": the best candidate, {best.effect} ({strength(best.p_value)})"
        out += f", still leaves {worst.test} at {p_text(worst.p_value)}" if worst else ""
    out += (
        f". A generic {correction['model']} reduces chi2 from {correction['chi2_before']:.4g} "
        f"to {correction['chi2_after']:.4g} (noise alone would leave about "
        f"{correction['noise_chi2']:.4g}"
    )
    share = correction.get("structure_fraction")
    out += f"; {share:.0%} of the misfit above noise is structure)." if share is not None else ")."
    model = correction.get("input_error_model")
    if model:
        out += (
            f" An error model driven by the inputs ({model['model']}) lowers chi2 by "
            f"{model['chi2_drop']:.3g} with {model['df']} coefficients where no move of the "
            f"model's parameters can ({strength(model['p_value'])})."
        )
    dynamics = correction.get("dynamics") or {}
    mode = dynamics.get("mode")
    if mode:
        out += (
            f" The residuals carry a mode near {mode['frequency_hz']:.3g} Hz "
            f"(damping ratio {mode['damping']:.2g})."
        )
    lead = dynamics.get("leads")
    if lead:
        out += f" {lead['output']} leads {lead['other']} by {lead['seconds']:.3g} s."
    return out
