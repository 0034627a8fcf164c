"""The result of a diagnosis (contract: "Diagnose result")."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.discrepancy.residual_tests import TestResult, Window
from fmuid.estimation.result import SCHEMA_VERSION, Cost
from fmuid.provenance import Provenance, entry
from fmuid.readable import p_text

if TYPE_CHECKING:
    from fmuid.estimation.problem import Problem


@dataclass(frozen=True)
class CandidateScore:
    """How well one candidate explains the data.

    Attributes
    ----------
    effect
        Catalogue name.
    parameters
        Added parameter names and their fitted values.
    chi2
        Chi2 of the augmented fit.
    p_value
        Likelihood-ratio test against the model it augments: the chi2 drop (``statistic``)
        against chi-bar-square (off value at a bound) or chi2 (df = added parameters).
    bic
        ``chi2 + k ln(n)`` of the augmented model (k free parameters, n data).
    stage
        1 for the first round, 2 for the second (on top of the first effect).
    statistic
        The chi2 drop.
    p_adjusted
        ``p_value`` adjusted for the scan over every candidate of the round (min-P).
    fitted
        Whether every parameter was fitted (else the linearised screen's value).

    """

    effect: str
    parameters: dict[str, float]
    chi2: float
    p_value: float
    bic: float
    stage: int = 1
    statistic: float = 0.0
    p_adjusted: float = 1.0
    fitted: bool = True

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form."""
        return {
            "effect": self.effect,
            "parameters": {k: float(v) for k, v in self.parameters.items()},
            "chi2": float(self.chi2),
            "p_value": float(self.p_value),
            "bic": float(self.bic),
            "stage": self.stage,
            "statistic": float(self.statistic),
            "p_adjusted": float(self.p_adjusted),
            "fitted": self.fitted,
        }


@dataclass(frozen=True)
class AddedEstimate:
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

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form."""
        return {
            "estimate": float(self.estimate),
            "ci": [None if v is None else float(v) for v in self.ci],
            "confidence": self.confidence,
            "unit": self.unit,
            "off": float(self.off),
            "excludes_off": self.excludes_off,
        }


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

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form."""
        return {
            "effect": self.effect,
            "label": self.label,
            "description": self.description,
            "parameters": {k: v.to_dict() for k, v in self.parameters.items()},
            "chi2_before": float(self.chi2_before),
            "chi2_after": float(self.chi2_after),
            "chi2_drop": float(self.chi2_before - self.chi2_after),
            "p_value": float(self.p_value),
            "p_adjusted": float(self.p_adjusted),
            "coupling_error": self.coupling_error,
        }


@dataclass(frozen=True)
class StageCost:
    """What one step of a diagnosis cost: FMU simulations and wall time in seconds."""

    stage: str
    simulations: int
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form ``{"stage": ..., "simulations": ..., "seconds": ...}``."""
        return {"stage": self.stage, **Cost(self.simulations, self.seconds).to_dict()}


@dataclass(frozen=True)
class Diagnosis:
    """Outcome of ``fmuid.diagnose``: is there a mismatch, where, what explains it.

    ``to_dict`` gives the contract's JSON plus the extra keys documented there.
    """

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
    indistinguishable: tuple[dict[str, Any], ...] = ()
    generic_correction: dict[str, Any] | None = None
    absorbed: dict[str, Any] = field(default_factory=dict)
    scan_p_value: float | None = None
    fmu: dict[str, str] = field(default_factory=dict)
    cost: Cost = Cost(0, 0.0)
    stages: tuple[StageCost, ...] = ()
    """The cost of each step, in order (they sum to ``cost``; none in results of before 2026-11)."""
    units: dict[str, str] = field(default_factory=dict)
    discriminating_experiment: dict[str, Any] | None = None
    effects: tuple[EffectStep, ...] = ()
    validation: tuple[dict[str, Any], ...] = ()
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

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form of the contract (plus extra keys)."""
        params = {
            name: {"before": self.parameters_before.get(name), "after": value}
            for name, value in self.parameters_after.items()
        }
        for name, value in self.parameters_before.items():
            params.setdefault(name, {"before": value, "after": None})
        out = {
            "kind": "diagnose",
            "schema_version": SCHEMA_VERSION,
            "mismatch": self.mismatch,
            "evidence": [t.to_dict() for t in self.evidence],
            "location": self.location,
            "effect": self.effect,
            "description": self.description,
            "candidates": [c.to_dict() for c in self.candidates],
            "added_parameters": {k: v.to_dict() for k, v in self.added_parameters.items()},
            "chi2_before": float(self.chi2_before),
            "chi2_after": float(self.chi2_after),
            "parameters": params,
            "fmu": dict(self.fmu),
            "n_data": self.n_data,
            "false_alarm": self.false_alarm,
            "second_effect": self.second_effect,
            "indistinguishable": list(self.indistinguishable),
            "absorbed": self.absorbed,
            "scan_p_value": None if self.scan_p_value is None else float(self.scan_p_value),
            "lrt_p_value": None if self.lrt_p_value is None else float(self.lrt_p_value),
            "bic_before": float(self.bic_before),
            "bic_after": float(self.bic_after),
            "whiteness_before": self.whiteness(after=False),
            "whiteness_after": self.whiteness(after=True),
            "windows": [w.to_dict() for w in self.windows],
            "tests_before": [t.to_dict() for t in self.tests_before],
            "tests_after": [t.to_dict() for t in self.tests_after],
            "generic_correction": self.generic_correction,
            "cost": {**self.cost.to_dict(), "stages": [s.to_dict() for s in self.stages]},
            "units": dict(self.units),
            "discriminating_experiment": self.discriminating_experiment,
            "effects": [e.to_dict() for e in self.effects],
            "validation": list(self.validation),
            **entry(self.provenance),
        }
        return {"verdict": verdict(out), **out}

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


def _validation_clause(d: dict[str, Any]) -> str:
    """``; held-out RMS error of x 7.1e-03 -> 9.8e-04 (test.csv)`` for the named model."""
    parts = []
    for v in d.get("validation") or []:
        if v.get("rms_by_step"):
            parts.append(
                f"{v['output']} {v['rms_base']:.3g} -> {v['rms_final']:.3g} ({v['experiment']})"
            )
    return f"; held-out RMS simulation error {', '.join(parts)}" if parts else ""


def verdict(d: dict[str, Any]) -> str:
    """One sentence from a diagnosis' JSON: mismatch or not, what explains it, how strongly.

    Effect names of earlier versions read as today's (``sensor_lag`` as ``output_lag``).
    """
    from fmuid.discrepancy.words import effect_of

    level = d.get("false_alarm", 0.01)
    if not d.get("mismatch"):
        return f"No mismatch: no test rejects the model at a family-wise level of {level:g}."
    effect = d.get("effect")
    evidence = d.get("evidence") or []
    hidden = bool(evidence) and all(
        e.get("test") in ("generic_error_model", "catalogue_scan", "experiments_disagree")
        for e in evidence
    )
    if effect in (None, "unexplained"):
        outputs = ", ".join((d.get("location") or {}).get("outputs") or []) or "the outputs"
        note = ", although the base model's residuals look like noise" if hidden else ""
        return f"A mismatch in {outputs} that no catalogue entry explains{note}."
    ties = [t["effect"] if isinstance(t, dict) else str(t) for t in d.get("indistinguishable", [])]
    named = [effect_of(e["effect"]) for e in d.get("effects") or []] or [effect_of(effect)]
    p = d.get("lrt_p_value")
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
        out += f"; {', '.join(effect_of(t) for t in ties)} explain{'s' if len(ties) == 1 else ''}"
        out += " it equally well"
    return out + _validation_clause(d) + "."
