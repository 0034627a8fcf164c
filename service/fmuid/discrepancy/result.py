"""The result of a diagnosis (contract: "Diagnose result")."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.discrepancy.residual_tests import TestResult, Window
from fmuid.discrepancy.schema import (
    AbsorbedOut,
    AddedOut,
    CandidateScore,
    CorrectionOut,
    DiagnosisOut,
    TieOut,
)
from fmuid.estimation.result import Cost
from fmuid.estimation.schema import Written
from fmuid.experiment_design.schema import DiscriminatingOut
from fmuid.provenance import Provenance
from fmuid.readable import p_text

if TYPE_CHECKING:
    from fmuid.estimation.problem import Problem
    from fmuid.estimation.validation import ValidationEntry

__all__ = [
    "AddedEstimate",
    "CandidateScore",
    "Diagnosis",
    "EffectStep",
    "StageCost",
]

HIDDEN_BY = ("generic_error_model", "catalogue_scan", "experiments_disagree")
"""Tests that find a mismatch the base model's residuals do not show."""


@dataclass(frozen=True)
class AddedEstimate(Written):
    """Estimate and profile-likelihood interval of an added parameter.

    Attributes
    ----------
    estimate
        Best-fit value.
    ci
        Pointwise profile-likelihood interval at ``confidence``; an end is ``None`` when the
        profile does not cross the threshold inside the bounds.
    confidence
        Level of ``ci``.
    unit, off
        Unit and the value that switches the effect off.
    excludes_off
        Whether ``ci`` rules the off value out.

    """

    estimate: float
    ci: tuple[float | None, float | None]
    confidence: float
    unit: str
    off: float
    excludes_off: bool

    schema = AddedOut

    @classmethod
    def of(
        cls,
        value: float,
        p: AddedParameter,
        ci: tuple[float | None, float | None],
        confidence: float,
    ) -> AddedEstimate:
        """Estimate, interval and the off-value check of the added parameter ``p``."""
        lo, hi = ci
        if p.off_side == "low":
            excludes = lo is not None
        elif p.off_side == "high":
            excludes = hi is not None
        else:
            low = lo if lo is not None else p.spec.lower
            high = hi if hi is not None else p.spec.upper
            excludes = not low <= p.off <= high
        return cls(value, ci, confidence, p.unit, p.off, bool(excludes))


@dataclass(frozen=True)
class EffectStep:
    """One effect added by the forward selection, with what it bought.

    Attributes
    ----------
    effect, label
        The effect's name and its label with the parameter names.
    description
        Its sentence in physical words at the fitted values.
    parameters
        Estimates and intervals of its added parameters (from the final model's profiles).
    chi2_before, chi2_after
        Chi2 of the model before and after this step.
    p_value, p_adjusted
        Likelihood-ratio p-value of the step, and adjusted for its round's scan.
    coupling_error
        For effects on a fine grid (feedback, input effects, output lags): the largest change of
        the final model's predictions, in sigmas, when that grid's step is halved; None
        otherwise.
    steps_per_sample
        For those effects: fine-grid steps per median sample interval of the model after this
        step (4 by default, more when the step was refined, :mod:`.coupling`); None otherwise.

    """

    effect: str
    label: str
    description: str
    parameters: dict[str, AddedEstimate]
    chi2_before: float
    chi2_after: float
    p_value: float
    p_adjusted: float
    coupling_error: float | None = None
    steps_per_sample: float | None = None

    @property
    def chi2_drop(self) -> float:
        """The chi2 the step removed."""
        return self.chi2_before - self.chi2_after


@dataclass(frozen=True)
class StageCost:
    """What one step of a diagnosis cost: FMU simulations and wall time in seconds."""

    stage: str
    simulations: int
    seconds: float


@dataclass(frozen=True)
class Diagnosis(Written):
    """Outcome of ``fmuid.diagnose``: is there a mismatch, where, what explains it.

    ``to_dict`` writes the JSON of :class:`~fmuid.discrepancy.schema.DiagnosisOut` (the
    contract's, plus the extra keys documented there). Its ties, absorbed parameters, generic
    correction and discriminating experiment are that schema's blocks; ``location`` is a dict
    (the plots and the engine read it by key) that the schema types when it is written.
    """

    schema = DiagnosisOut

    mismatch: bool
    false_alarm: float
    evidence: tuple[TestResult, ...]
    tests_before: tuple[TestResult, ...]
    tests_after: tuple[TestResult, ...]
    location: dict[str, Any]
    windows: tuple[Window, ...]
    effect: str | None
    description: str
    candidates: tuple[CandidateScore, ...]
    added_parameters: dict[str, AddedEstimate]
    chi2_before: float
    chi2_after: float
    n_data: int
    lrt_p_value: float | None
    bic_before: float
    bic_after: float
    parameters_before: dict[str, float]
    parameters_after: dict[str, float]
    second_effect: str | None = None
    indistinguishable: tuple[TieOut, ...] = ()
    generic_correction: CorrectionOut | None = None
    absorbed: dict[str, AbsorbedOut] = field(default_factory=dict)
    scan_p_value: float | None = None
    fmu: dict[str, str] = field(default_factory=dict)
    cost: Cost = Cost(0, 0.0)
    stages: tuple[StageCost, ...] = ()
    """The cost of each step, in order (they sum to ``cost``; none in results of before 2026-11)."""
    units: dict[str, str] = field(default_factory=dict)
    discriminating_experiment: DiscriminatingOut | None = None
    effects: tuple[EffectStep, ...] = ()
    validation: tuple[ValidationEntry, ...] = ()
    provenance: Provenance | None = None
    problem: Problem | None = field(default=None, repr=False, compare=False)
    """The problem the stage computed it on (set by ``fmuid.fit``, ``profile``, ``diagnose``;
    not written to the JSON): ``write_report(result, folder)`` needs nothing else."""

    def whiteness(self, after: bool) -> dict[str, float]:
        """Ljung-Box p-value per ``experiment/output``, before or after the augmentation."""
        tests = self.tests_after if after else self.tests_before
        return {
            f"{t.experiment}/{t.output}": float(t.p_value)
            for t in tests
            if t.test == "residual_whiteness"
        }

    def verdict(self) -> str:
        """One sentence: mismatch or not, what explains it, how strongly.

        Effect names of earlier versions read as today's (``sensor_lag`` as ``output_lag``).
        """
        from fmuid.discrepancy.words import effect_of

        if not self.mismatch:
            return (
                "No mismatch: no test rejects the model at a family-wise level of "
                f"{self.false_alarm:g}."
            )
        hidden = bool(self.evidence) and all(e.test in HIDDEN_BY for e in self.evidence)
        if self.effect in (None, "unexplained"):
            outputs = ", ".join(self.location.get("outputs") or []) or "the outputs"
            note = ", although the base model's residuals look like noise" if hidden else ""
            return f"A mismatch in {outputs} that no catalogue entry explains{note}."
        ties = [t.effect for t in self.indistinguishable]
        named = [effect_of(e.effect) for e in self.effects] or [effect_of(self.effect)]
        p = self.lrt_p_value
        words = (
            "evidence"
            if p is None
            else ("very strong" if p < 1e-6 else "strong" if p < 1e-3 else "moderate")
            + f" evidence ({p_text(p)})"
        )
        what = ", then ".join(named)
        verb = "explains" if len(named) == 1 else "explain"
        if "unexplained" in ties:
            out = (
                f"Physics outside the catalogue explains the mismatch as well as {what}, which "
                f"{verb} it with {words}"
            )
            ties = [t for t in ties if t != "unexplained"]
        else:
            out = f"{what} {verb} the mismatch, with {words}"
        if hidden:
            out += ", although the base model's residuals look like noise"
        if ties:
            out += (
                f"; {', '.join(effect_of(t) for t in ties)} explain{'s' if len(ties) == 1 else ''}"
            )
            out += " it equally well"
        loose = [
            effect_of(e.effect)
            for e in self.effects
            if e.parameters and not any(p.excludes_off for p in e.parameters.values())
        ]
        if loose:
            out += (
                f"; but the interval of {' and of '.join(loose)} holds the off value: the data "
                "do not pin that term down"
            )
        return out + self._validation_clause() + "."

    def _validation_clause(self) -> str:
        """``; held-out RMS error of x 7.1e-03 -> 9.8e-04 (test.csv)`` for the named model."""
        parts = [
            f"{v.output} {v.rms_base:.3g} -> {v.rms_final:.3g} ({v.experiment})"
            for v in self.validation
            if v.rms_by_step and v.rms_final is not None
        ]
        return f"; held-out RMS simulation error {', '.join(parts)}" if parts else ""

    def to_frame(self) -> Any:
        """Return a pandas table of the parameters before and after, and the added ones.

        Columns: ``role`` (``model`` or ``added``), ``before``, ``after``, ``unit``, ``ci_low``,
        ``ci_high`` (the added parameters' intervals; open ends are NaN).
        """
        from fmuid.frames import nan_if_none, parameter_frame

        rows: dict[str, dict[str, Any]] = {}
        for name in {**self.parameters_before, **self.parameters_after}:
            rows[name] = {
                "role": "model",
                "before": nan_if_none(self.parameters_before.get(name)),
                "after": nan_if_none(self.parameters_after.get(name)),
                "unit": self.units.get(name, ""),
                "ci_low": float("nan"),
                "ci_high": float("nan"),
            }
        for name, added in self.added_parameters.items():
            rows[name] = {
                "role": "added",
                "before": added.off,
                "after": added.estimate,
                "unit": added.unit,
                "ci_low": nan_if_none(added.ci[0]),
                "ci_high": nan_if_none(added.ci[1]),
            }
        return parameter_frame(rows)
