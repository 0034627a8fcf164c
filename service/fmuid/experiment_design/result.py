"""The design result: ranked designs, what no design identifies, trade-offs, cost."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from fmuid.estimation.result import Cost
from fmuid.estimation.schema import Written
from fmuid.experiment_design.schema import DesignResultOut
from fmuid.experiment_design.signals import Trial, trial_from_dict
from fmuid.experiment_design.verify import Verification
from fmuid.provenance import Provenance, read


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

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RankedDesign:
        """Build a design back from :meth:`to_dict` (a verification keeps its median widths)."""
        predicted = {
            n: {
                "ci": [_float_or_none(e) for e in p["ci"]],
                "status": p["status"],
                **({"width_z": _float(p["width"])} if "width" in p else {}),
            }
            for n, p in data["predicted"].items()
        }
        verified = data.get("verified")
        trial = trial_from_dict(data["experiment"])
        if "duration" in data.get("cost", {}):  # unrounded, unlike the experiment's
            trial = trial.with_(duration=float(data["cost"]["duration"]))
        return cls(
            trial=trial,
            score=_float(data["score"]),
            predicted=predicted,
            verified=None if verified is None else _verification(verified),
        )


@dataclass(frozen=True)
class DesignResult(Written):
    """What ``fmuid design`` returns; ``to_dict`` writes :class:`.schema.DesignResultOut`.

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
    provenance: Provenance | None = None

    schema = DesignResultOut

    @property
    def best(self) -> RankedDesign:
        """The recommended design."""
        return self.designs[0]

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DesignResult:
        """Build a design result back from :meth:`to_dict` (``fmuid.load_result`` calls it).

        Equal to the saved result in everything its JSON holds; a verification's per-draw
        widths come back as their median, and its cost as zero.
        """
        cost = dict(data.get("cost", {}))
        designs = tuple(RankedDesign.from_dict(d) for d in data["designs"])
        return cls(
            fmu_sha256=str(data["fmu"]["sha256"]),
            model_name=str(data["fmu"]["model_name"]),
            input_name=str(data["designs"][0]["experiment"]["input_variable"]) if designs else "",
            criterion=str(data["criterion"]),
            designs=designs,
            not_identifiable_by_any=list(data.get("not_identifiable_by_any", ())),
            tradeoffs=dict(data.get("tradeoffs", {})),
            screened=int(data.get("screened", 0)),
            cost=Cost(int(cost.pop("simulations", 0)), float(cost.pop("seconds", 0.0))),
            stage_seconds={k: float(v) for k, v in cost.items()},
            provenance=read(data),
        )

    def to_frame(self) -> Any:
        """Return one row per design: settings, score, predicted widths, verified counts.

        Raises
        ------
        ImportError
            If pandas is not installed (the ``report`` extra).
        """
        from fmuid.frames import pandas_module

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


def _verification(d: dict[str, Any]) -> Verification:
    """Build a verification back from its JSON form (one width per parameter: the median)."""
    return Verification(
        draws=int(d["draws"]),
        identifiable={n: int(k) for n, k in d["identifiable"].items()},
        open_ended={n: int(k) for n, k in d.get("open_ended", {}).items()},
        widths={n: [_float(w)] for n, w in d["median_width"].items()},
        simulations=0,
        seconds=0.0,
    )


def _float(v: Any) -> float:
    """Return a JSON number as a float; ``null`` (a non-finite number saved) as NaN."""
    return math.nan if v is None else float(v)


def _float_or_none(v: Any) -> float | None:
    return None if v is None else float(v)
