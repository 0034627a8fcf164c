"""The schema of a design result's JSON (``fmuid design``), and of a discriminating test.

A discriminating test is one proposed to tell two hypotheses apart (a diagnosis'
``discriminating_experiment``).

Each model is built from its object by ``of`` and dumped by the object's ``to_dict``
(:class:`~fmuid.estimation.schema.Written`): the one definition of the JSON.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Literal, Self

from pydantic import Field
from scipy.stats import chi2 as chi2_dist

from fmuid.estimation.schema import (
    Block,
    CostOut,
    FmuOut,
    Interval,
    ResultBlock,
    omitted_if_none,
)
from fmuid.readable import shown_seconds

if TYPE_CHECKING:
    from fmuid.experiment_design.discriminate import Discrimination
    from fmuid.experiment_design.result import DesignResult, RankedDesign
    from fmuid.experiment_design.signals import Trial
    from fmuid.experiment_design.verify import Verification

WIDTH_UNIT = "decades (log-scaled parameters); open ends at the bound"
"""The unit of a verification's median widths, as written."""


def _digits(value: float) -> float:
    """Round to 6 significant digits (how a test's numbers are written)."""
    return float(f"{value:.6g}")


def _finite(value: float | None) -> float | None:
    """Return a number, or None when it is absent or not finite (JSON has no infinity)."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


class DesignExperimentOut(Block):
    """A test: the input family and its settings, duration [s], sampling rate, sensors."""

    input: str
    input_variable: str
    settings: dict[str, float]
    duration: float
    rate_hz: float
    outputs: list[str]
    fixed: dict[str, float] = {}

    @classmethod
    def of_trial(cls, trial: Trial, input_name: str) -> Self:
        """Build it from a :class:`~fmuid.experiment_design.signals.Trial` (6 digits)."""
        return cls(
            input=trial.family,
            input_variable=input_name,
            settings={k: _digits(v) for k, v in trial.settings.items()},
            duration=_digits(trial.duration),
            rate_hz=_digits(trial.rate_hz),
            outputs=list(trial.outputs),
            fixed={k: _digits(v) for k, v in trial.fixed.items()},
        )


class PredictedOut(Block):
    """A parameter's interval and label predicted from the Fisher information."""

    ci: Interval
    status: str
    width: float | None = Field(default=None, description="Interval width (decades for log).")

    @classmethod
    def of(cls, obj: dict[str, Any]) -> Self:
        """Build it from a ranked design's ``predicted`` entry (``width_z``: the width)."""
        width = {"width": _finite(obj["width_z"])} if "width_z" in obj else {}
        ci = tuple(_finite(e) for e in obj["ci"])
        return cls(ci=ci, status=obj["status"], **width)  # type: ignore[arg-type]


class VerifiedOut(Block):
    """Profiles on simulated data of a design: draws, and how often each parameter was settled."""

    draws: int
    identifiable: dict[str, int]
    open_ended: dict[str, int] = {}
    median_width: dict[str, float | None] = {}
    width_unit: str = ""

    @classmethod
    def of(cls, obj: Verification) -> Self:
        """Build it from a :class:`~fmuid.experiment_design.verify.Verification`."""
        return cls(
            draws=obj.draws,
            identifiable=obj.identifiable,
            open_ended=obj.open_ended,
            median_width={n: obj.median_width(n) for n in obj.widths},
            width_unit=WIDTH_UNIT,
        )


class TestCostOut(Block):
    """What a design asks of the test rig: its duration [s] (unrounded) and sensors."""

    duration: float
    sensors: int


class DesignOut(Block):
    """One ranked design."""

    experiment: DesignExperimentOut
    predicted: dict[str, PredictedOut]
    verified: VerifiedOut | None
    score: float | None
    cost: TestCostOut | None = None

    @classmethod
    def of_design(cls, obj: RankedDesign, input_name: str) -> Self:
        """Build it from a :class:`~fmuid.experiment_design.result.RankedDesign`."""
        return cls(
            experiment=DesignExperimentOut.of_trial(obj.trial, input_name),
            predicted={n: PredictedOut.of(p) for n, p in obj.predicted.items()},
            verified=None if obj.verified is None else VerifiedOut.of(obj.verified),
            score=_finite(obj.score),
            cost=TestCostOut(duration=obj.trial.duration, sensors=len(obj.trial.outputs)),
        )


class NotIdentifiableOut(Block):
    """Parameters no feasible design identifies apart."""

    parameters: list[str]
    meaning: str


class TradeoffOut(Block):
    """The recommended design with one change: its score, and predicted widths and labels."""

    score: float | None = None
    score_ratio: float | None = None
    width: dict[str, float | None] = {}
    status: dict[str, str] = {}


class DesignCostOut(CostOut):
    """What a design cost, with the screen and the verification apart (as the report rounds)."""

    screen_seconds: float | None = omitted_if_none()
    verify_seconds: float | None = omitted_if_none()


class DesignResultOut(ResultBlock):
    """Result of an experiment design (``fmuid design``, job kind ``design``)."""

    kind: Literal["design"] = "design"
    fmu: FmuOut
    criterion: Literal["D", "E"]
    designs: list[DesignOut]
    not_identifiable_by_any: list[NotIdentifiableOut]
    tradeoffs: dict[str, TradeoffOut] = {}
    screened: int = 0
    cost: DesignCostOut

    @classmethod
    def of(cls, obj: DesignResult) -> Self:
        """Build it from a :class:`~fmuid.experiment_design.result.DesignResult`."""
        cost = CostOut.of(obj.cost)
        stages = {k: shown_seconds(v) for k, v in obj.stage_seconds.items()}
        return cls.model_validate(
            {
                "fmu": FmuOut(sha256=obj.fmu_sha256, model_name=obj.model_name),
                "criterion": obj.criterion,
                "designs": [DesignOut.of_design(d, obj.input_name) for d in obj.designs],
                "not_identifiable_by_any": [
                    NotIdentifiableOut(parameters=c["parameters"], meaning=c["meaning"])
                    for c in obj.not_identifiable_by_any
                ],
                "tradeoffs": obj.tradeoffs,
                "screened": obj.screened,
                "cost": DesignCostOut(simulations=cost.simulations, seconds=cost.seconds, **stages),
                "provenance": obj.provenance,
            }
        )


class DiscriminatingOut(Block):
    """A test that would tell two hypotheses apart, and how well (noise-free fits)."""

    experiment: DesignExperimentOut
    hypotheses: list[str]
    expected_separation: dict[str, float] = Field(
        description="Chi2 of each hypothesis fitted to the other's predictions."
    )
    expected_chi2: float
    expected_p_value: float
    screened: int
    noise_sigma: dict[str, float] = {}
    confirmed: bool = True
    time: list[float] = Field(default=[], description="Sensor times [s] (6 digits).")
    predictions: dict[str, dict[str, list[float]]] = Field(
        default={}, description="Each hypothesis's noise-free outputs at ``time`` (6 digits)."
    )

    @classmethod
    def of(cls, obj: Discrimination) -> Self:
        """Build it from a :class:`~fmuid.experiment_design.discriminate.Discrimination`."""
        lam = obj.expected_chi2
        return cls(
            experiment=DesignExperimentOut.of_trial(obj.trial, obj.input_name),
            hypotheses=list(obj.hypotheses),
            expected_separation={k: round(v, 4) for k, v in obj.separation.items()},
            expected_chi2=round(lam, 4),
            expected_p_value=float(chi2_dist.sf(lam, 1)),
            screened=obj.screened,
            noise_sigma=obj.sigma,
            confirmed=obj.confirmed,
            time=[_digits(t) for t in obj.time],
            predictions={
                h: {o: [_digits(v) for v in y] for o, y in ys.items()}
                for h, ys in obj.predictions.items()
            },
        )
