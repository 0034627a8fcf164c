"""Identifiability after the augmentation: which original parameters the added term absorbs.

The original free parameters are profiled on the base model and again on the augmented model
(the added term free), at the study's confidence. A parameter is reported as absorbing the
effect when, once the term is free, its estimate moves by more than the half-width of its
interval before, its interval widens by more than :data:`WIDENING`, or its label changes: the
base fit had moved it to hide the effect, or the data cannot separate it from the term.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.profiling.engine import profile_problem
from fmuid.profiling.health import Health
from fmuid.profiling.result import ParameterProfile, ProfileResult
from fmuid.profiling.walk import WalkOptions

WIDENING = 1.5
"""Interval width ratio (after / before) beyond which a parameter is said to absorb the term."""


def _entry(p: ParameterProfile) -> dict[str, Any]:
    return {
        "estimate": float(p.estimate),
        "ci": [None if v is None else float(v) for v in p.ci_pointwise],
        "status": p.status,
    }


def _width(ci: tuple[float | None, float | None]) -> float | None:
    lo, hi = ci
    return None if lo is None or hi is None else hi - lo


def compare(before: ProfileResult, after: ProfileResult, names: list[str]) -> dict[str, Any]:
    """Intervals and labels before and after, and whether each parameter absorbs the term."""
    out: dict[str, Any] = {}
    for name in names:
        b, a = before.parameters[name], after.parameters[name]
        wb, wa = _width(b.ci_pointwise), _width(a.ci_pointwise)
        shift = None
        if wb:
            shift = abs(a.estimate - b.estimate) / (wb / 2)
        ratio = None if wb is None or wa is None or wb == 0 else wa / wb
        reasons = []
        if shift is not None and shift > 1.0:
            reasons.append("estimate moved beyond its interval")
        if (ratio is not None and ratio > WIDENING) or (wb is not None and wa is None):
            reasons.append("interval widened")
        if a.status != b.status:
            reasons.append(f"label changed to {a.status}")
        out[name] = {
            "before": _entry(b),
            "after": _entry(a),
            "shift_in_half_widths": shift,
            "width_ratio": ratio,
            "absorbs": bool(reasons),
            "reasons": reasons,
        }
    return out


def absorbed(
    base: Problem,
    base_fit: FitResult,
    augmented: Problem,
    augmented_fit: FitResult,
    workers: int,
    walk: WalkOptions,
    executor: Any = None,
    health: Health | None = None,
) -> dict[str, Any]:
    """Profile the original parameters before and after; return the comparison.

    A per-experiment value (an initial state, ``Spec.per_experiment``) is left out: one per
    record, it would double the profiles for every record added and says nothing of the physics.

    ``augmented`` must be set at the study's confidence (its added parameters are free but not
    profiled). ``executor``: the diagnosis's task engine (or a ``dask.distributed.Client``) to
    run the branches on, as the diagnosis's other profiles; else ``workers`` local processes.

    The two fits are profiled as the diagnosis made them: no re-fits of the base fit from
    diverse starts (``CheckOptions.fit_starts``), which the profile of a whole-model fit
    makes. Every earlier stage measured the effect against these fits, so intervals around
    another optimum would not say what the term absorbs from them, and those re-fits start
    far from the data, where the simulations are slowest (about half of a diagnosis's time on
    ``bench/diagnose.py``'s concealed cases). ``health``: the health check of the augmented
    model at ``augmented_fit``'s point, where the profile of the added parameters made it
    there; the profile after reuses it (the same objective at the same point).
    """
    names = base.shared_names
    only = names if len(names) < base.n_free else None
    given = replace(walk, checks=replace(walk.checks, fit_starts=0))
    before = profile_problem(
        base, base_fit, only=only, workers=workers, executor=executor, options=given
    )
    after = profile_problem(
        augmented,
        augmented_fit,
        only=names,
        workers=workers,
        executor=executor,
        options=given,
        health=health,
    )
    return compare(before, after, names)
