"""The schema of a diagnosis' JSON (``fmuid diagnose``, job kind ``diagnose``).

Each model is built from its object by ``of`` and dumped by the object's ``to_dict``
(:class:`~fmuid.estimation.schema.Written`): the one definition of the JSON. The blocks that
the diagnosis holds as dicts (``location``, ``indistinguishable``, ``absorbed``,
``generic_correction``) are typed here; a key they do not name is refused when written.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal, Self

from pydantic import ConfigDict, Field

from fmuid.estimation.schema import (
    Block,
    CostOut,
    Interval,
    ResultBlock,
    ValidationOut,
    omitted_if_none,
)
from fmuid.experiment_design.schema import DiscriminatingOut

if TYPE_CHECKING:
    from fmuid.discrepancy.result import Diagnosis, StageCost


class EvidenceOut(Block):
    """One residual test (``output``/``experiment`` absent for a test over all of them)."""

    test: str
    output: str | None = omitted_if_none()
    experiment: str | None = omitted_if_none()
    p_value: float
    statistic: float = 0.0
    df: float | None = omitted_if_none("Degrees of freedom, when the test has any.")


class WindowOut(Block):
    """A time window [s] in which one series' residuals concentrate."""

    experiment: str
    output: str
    window: tuple[float, float]
    score: float

    @classmethod
    def of(cls, obj: Any) -> Self:
        """Build it from a :class:`~fmuid.discrepancy.residual_tests.Window`."""
        return cls(
            experiment=obj.experiment,
            output=obj.output,
            window=(obj.start, obj.end),
            score=obj.score,
        )


class CandidateScore(Block):
    """How well one candidate explains the data (the object and its JSON).

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

    model_config = ConfigDict(frozen=True)

    effect: str
    parameters: dict[str, float]
    chi2: float
    p_value: float
    bic: float
    stage: int = 1
    statistic: float = 0.0
    p_adjusted: float = 1.0
    fitted: bool = True

    def model_post_init(self, context: Any, /) -> None:
        """Write every field (it is an object of the result, not a block read from a dict)."""
        self.model_fields_set.update(type(self).model_fields)


class AddedOut(Block):
    """Estimate and profile-likelihood interval of an added parameter."""

    estimate: float
    ci: Interval
    confidence: float
    unit: str = ""
    off: float = Field(description="The value that switches the effect off.")
    excludes_off: bool


class EffectStepOut(Block):
    """One effect added by the forward selection, with what it bought."""

    effect: str
    label: str = ""
    description: str = ""
    parameters: dict[str, AddedOut] = {}
    chi2_before: float
    chi2_after: float
    chi2_drop: float = 0.0
    p_value: float
    p_adjusted: float
    coupling_error: float | None = None
    steps_per_sample: float | None = omitted_if_none(
        "Fine-grid steps per median sample interval of the model after this step (effects on "
        "the fine grid only)."
    )


class StageCostOut(CostOut):
    """What one step of a diagnosis cost (``stage``: e.g. ``scan``, ``profiles``)."""

    stage: str

    @classmethod
    def of(cls, obj: StageCost) -> Self:
        """Build it from a :class:`~fmuid.discrepancy.result.StageCost` (seconds to the ms)."""
        cost = CostOut.of(obj)
        return cls(stage=obj.stage, simulations=cost.simulations, seconds=cost.seconds)


class DiagnosisCostOut(CostOut):
    """What a diagnosis cost, and each of its steps in order (they sum to the total)."""

    stages: list[StageCostOut] = Field(
        default=[], description="The cost of each step (none in results of before 2026-11)."
    )


class BinsOut(Block):
    """Binned means of the weighted residuals (for the figure)."""

    centre: list[float]
    mean: list[float]
    stderr: list[float]


class LevelOut(Block):
    """Where in an output's range, and in its rate's, the base fit's misfit sits."""

    pattern: str | None
    p_value: float
    share: float
    tests: dict[str, float] = Field(description="Each shape's p-value.")
    words: str = ""
    by_level: BinsOut
    by_rate: BinsOut
    unit: str | None = None


class LocationOut(Block):
    """Where the mismatch is: outputs, experiments, time windows [s], band [Hz]."""

    basis: Literal["residuals", "effect"] | None = None
    outputs: list[str] = []
    experiments: list[str] = []
    time_windows: list[tuple[float, float]] = []
    frequency_hz: tuple[float, float] | None = None
    chi2_gain: dict[str, float] = Field(default={}, description="Per ``experiment/output``.")
    levels: dict[str, LevelOut] = {}


class TieOut(Block):
    """A candidate (or the generic error model) that explains the data as well as the named.

    Results of earlier versions name only the effect and its parameters.
    """

    effect: str
    model: str | None = Field(default=None, description="The generic error model's words.")
    parameters: dict[str, float] = {}
    chi2: float | None = None
    test: Literal["equal_predictions", "vuong"] | None = None
    statistic: float | None = None
    p_value: float | None = None
    max_difference_sigma: float | None = Field(default=None, description="[sigma]")
    intervals: dict[str, AddedOut] = {}
    expected_separation: float | None = None

    @classmethod
    def of(cls, obj: Any) -> Self:
        """Build it from a :class:`~fmuid.discrepancy.decide.Tie`."""
        return cls(
            effect=obj.fit.candidate.effect,
            parameters=obj.fit.values,
            chi2=obj.fit.chi2,
            test=obj.test,
            statistic=obj.statistic,
            p_value=obj.p_value,
            max_difference_sigma=obj.max_difference,
        )


class AbsorbedEntryOut(Block):
    """A parameter's estimate, pointwise interval and label, before or after."""

    estimate: float
    ci: Interval
    status: str


class AbsorbedOut(Block):
    """Whether an original parameter absorbs the added term, and why."""

    before: AbsorbedEntryOut
    after: AbsorbedEntryOut
    shift_in_half_widths: float | None
    width_ratio: float | None
    absorbs: bool
    reasons: list[str] = []


class ModeOut(Block):
    """An oscillatory pole pair: frequency [Hz] and damping ratio."""

    frequency_hz: float
    damping: float


class CorrectionOutputOut(Block):
    """The ARX correction of one output."""

    chi2_before: float
    chi2_after: float
    n_parameters: int
    p_value: float
    mode: ModeOut | None = None


class LeadOut(Block):
    """Two outputs of one experiment whose residuals correlate most at a lag."""

    output: str
    other: str
    seconds: float
    correlation: float
    experiment: str


class DynamicsOut(Block):
    """The residual dynamics: extra mode, frequency band [Hz], which output leads."""

    mode: ModeOut | None = None
    frequency_hz: tuple[float, float] | None = None
    band_output: str | None = None
    leads: LeadOut | None = None


class InputErrorModelOut(Block):
    """The input-driven error model the generic test fitted."""

    model: str
    pole_hz: float
    chi2_drop: float
    df: float | None = None
    p_value: float


class CorrectionOut(Block):
    """The generic ARX correction of a fit's residuals (an unexplained mismatch's size)."""

    model: str
    chi2_before: float
    chi2_after: float
    n_parameters: int
    n_data: int
    noise_chi2: float
    structure_fraction: float | None = None
    p_value: float
    outputs: dict[str, CorrectionOutputOut] = {}
    dynamics: DynamicsOut | None = None
    input_error_model: InputErrorModelOut | None = None


class ParameterChangeOut(Block):
    """A model parameter's estimate before and after the augmentation."""

    before: float | None
    after: float | None


class FmuRefOut(Block):
    """The FMU diagnosed (empty in results of before 2026-09)."""

    sha256: str | None = None
    model_name: str | None = None


class DiagnosisOut(ResultBlock):
    """Result of a diagnosis (``fmuid diagnose``, job kind ``diagnose``)."""

    kind: Literal["diagnose"] = "diagnose"
    verdict: str = Field(default="", description="One sentence: what the diagnosis found.")
    mismatch: bool
    evidence: list[EvidenceOut] = []
    location: LocationOut = LocationOut()
    effect: str | None = None
    description: str = ""
    candidates: list[CandidateScore] = []
    added_parameters: dict[str, AddedOut] = {}
    chi2_before: float
    chi2_after: float
    parameters: dict[str, ParameterChangeOut] = {}
    fmu: FmuRefOut = FmuRefOut()
    n_data: int = 0
    false_alarm: float = 0.01
    second_effect: str | None = None
    indistinguishable: list[TieOut] = []
    absorbed: dict[str, AbsorbedOut] = {}
    scan_p_value: float | None = None
    lrt_p_value: float | None = None
    bic_before: float = 0.0
    bic_after: float = 0.0
    whiteness_before: dict[str, float] = Field(default={}, description="Ljung-Box p-values.")
    whiteness_after: dict[str, float] = {}
    windows: list[WindowOut] = []
    tests_before: list[EvidenceOut] = []
    tests_after: list[EvidenceOut] = []
    generic_correction: CorrectionOut | None = None
    cost: DiagnosisCostOut | None = None
    units: dict[str, str] = {}
    discriminating_experiment: DiscriminatingOut | None = None
    effects: list[EffectStepOut] = []
    validation: list[ValidationOut] = []

    @classmethod
    def of(cls, obj: Diagnosis) -> Self:
        """Build it from a :class:`~fmuid.discrepancy.result.Diagnosis`."""
        params = {
            name: ParameterChangeOut(before=obj.parameters_before.get(name), after=value)
            for name, value in obj.parameters_after.items()
        }
        for name, value in obj.parameters_before.items():
            params.setdefault(name, ParameterChangeOut(before=value, after=None))
        cost = CostOut.of(obj.cost)
        return cls.model_validate(
            {
                "verdict": obj.verdict(),
                "mismatch": obj.mismatch,
                "evidence": list(obj.evidence),
                "location": obj.location,
                "effect": obj.effect,
                "description": obj.description,
                "candidates": list(obj.candidates),
                "added_parameters": obj.added_parameters,
                "chi2_before": obj.chi2_before,
                "chi2_after": obj.chi2_after,
                "parameters": params,
                "fmu": obj.fmu,
                "n_data": obj.n_data,
                "false_alarm": obj.false_alarm,
                "second_effect": obj.second_effect,
                "indistinguishable": list(obj.indistinguishable),
                "absorbed": obj.absorbed,
                "scan_p_value": obj.scan_p_value,
                "lrt_p_value": obj.lrt_p_value,
                "bic_before": obj.bic_before,
                "bic_after": obj.bic_after,
                "whiteness_before": obj.whiteness(after=False),
                "whiteness_after": obj.whiteness(after=True),
                "windows": [WindowOut.of(w) for w in obj.windows],
                "tests_before": list(obj.tests_before),
                "tests_after": list(obj.tests_after),
                "generic_correction": obj.generic_correction,
                "cost": DiagnosisCostOut(
                    simulations=cost.simulations,
                    seconds=cost.seconds,
                    stages=[StageCostOut.of(s) for s in obj.stages],
                ),
                "units": obj.units,
                "discriminating_experiment": obj.discriminating_experiment,
                "effects": list(obj.effects),
                "validation": list(obj.validation),
                "provenance": obj.provenance,
            }
        )
