"""The design result: ranked designs, what no design identifies, trade-offs, cost."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from fmuid.estimation.result import Cost
from fmuid.experiment_design.signals import Trial
from fmuid.experiment_design.verify import Verification


@dataclass(frozen=True)
class RankedDesign:
    """One design with its screen score, predicted intervals and (for the best) profiles.

    Attributes
    ----------
    trial
        The test.
    score
        Worst case over the prior points of the confidence ellipsoid's half-width in fitted
        coordinates (D: geometric-mean axis, E: longest axis), times
        ``sqrt(duration / longest_test)``; lower is better.
    predicted
        Parameter -> ``{"ci", "status", "width_z"}`` at the nominal from the Fisher information.
    verified
        Profiles on simulated data, when this design was verified.

    """

    trial: Trial
    score: float
    predicted: dict[str, dict[str, Any]]
    verified: Verification | None = None

    def to_dict(self, input_name: str) -> dict[str, Any]:
        """Return the contract's design entry."""
        return {
            "experiment": self.trial.to_dict(input_name),
            "predicted": {
                n: {
                    "ci": [_num(e) for e in p["ci"]],
                    "status": p["status"],
                    **({"width": _num(p["width_z"])} if "width_z" in p else {}),
                }
                for n, p in self.predicted.items()
            },
            "verified": self.verified.to_dict() if self.verified is not None else None,
            "score": _num(self.score),
            "cost": {"duration": self.trial.duration, "sensors": len(self.trial.outputs)},
        }


@dataclass(frozen=True)
class DesignResult:
    """What ``fmuid design`` returns.

    Attributes
    ----------
    fmu_sha256, model_name
        The FMU.
    input_name
        The FMU input the tests drive.
    criterion
        ``"D"`` or ``"E"``.
    designs
        Ranked: verified designs first (most parameters identifiable in every draw, then the
        narrowest verified widths per unit time), then the rest by screen score.
    not_identifiable_by_any
        Null directions of the information of every screened design together.
    tradeoffs
        For the recommended design: score and predicted widths when a sensor is dropped or
        added, or the rate halved.
    screened
        Number of (input, settings, rate, sensor set) designs scored.
    cost
        Simulations and wall time, with the screen and the verification separately.

    """

    fmu_sha256: str
    model_name: str
    input_name: str
    criterion: str
    designs: tuple[RankedDesign, ...]
    not_identifiable_by_any: list[dict[str, Any]]
    tradeoffs: dict[str, dict[str, Any]]
    screened: int
    cost: Cost
    stage_seconds: dict[str, float] = field(default_factory=dict)

    @property
    def best(self) -> RankedDesign:
        """The recommended design."""
        return self.designs[0]

    def to_dict(self) -> dict[str, Any]:
        """Return the contract's JSON form."""
        return {
            "fmu": {"sha256": self.fmu_sha256, "model_name": self.model_name},
            "criterion": self.criterion,
            "designs": [d.to_dict(self.input_name) for d in self.designs],
            "not_identifiable_by_any": [
                {"parameters": c["parameters"], "meaning": c["meaning"]}
                for c in self.not_identifiable_by_any
            ],
            "tradeoffs": self.tradeoffs,
            "screened": self.screened,
            "cost": {
                **self.cost.to_dict(),
                **{k: round(v, 3) for k, v in self.stage_seconds.items()},
            },
        }

    def to_frame(self) -> Any:
        """Return one row per design: settings, score, predicted widths, verified counts.

        Raises
        ------
        ImportError
            If pandas is not installed (the ``report`` extra).
        """
        from fmuid.results import pandas_module

        rows = []
        for rank, d in enumerate(self.designs, 1):
            row: dict[str, Any] = {
                "rank": rank,
                "design": d.trial.label,
                "sensors": ", ".join(d.trial.outputs),
                "score": d.score,
            }
            for n, p in d.predicted.items():
                row[f"{n} width"] = p.get("width_z", math.nan)
                if d.verified is not None:
                    row[f"{n} verified"] = f"{d.verified.identifiable[n]}/{d.verified.draws}"
            rows.append(row)
        return pandas_module().DataFrame(rows)


def _num(v: Any) -> float | None:
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None
