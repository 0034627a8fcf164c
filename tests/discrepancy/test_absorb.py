"""The absorbed re-profiles keep the diagnosis's fits: no re-fits of the base fit from afar, and
no second health check of the augmented model at the point its added parameters were profiled."""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.discrepancy.test_parallel_scan import SPEC, offset_record

import fmuid.profiling.engine as profile_engine
from fmuid.discrepancy import DiagnoseOptions, diagnose
from fmuid.estimation.optimize import fit_problem
from fmuid.profiling.engine import profile_problem
from fmuid.stages import make_problem


@pytest.mark.slow
def test_the_absorbed_profiles_make_no_fit_check(
    msd_fmu: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    checks: list[int] = []
    real = profile_engine.check_fit

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        checks.append(1)
        return real(*args, **kwargs)

    healths: list[tuple[tuple[str, ...], bytes]] = []
    real_health = profile_engine.check_health

    def health(problem, z, *args, **kwargs):  # type: ignore[no-untyped-def]
        healths.append((tuple(problem.names), z.tobytes()))
        return real_health(problem, z, *args, **kwargs)

    monkeypatch.setattr(profile_engine, "check_fit", counted)
    monkeypatch.setattr(profile_engine, "check_health", health)
    data = [offset_record()]
    problem = make_problem(msd_fmu, data, SPEC)
    profile_problem(problem, fit_problem(problem, global_search=False))
    assert checks == [1]  # a whole-model profile of a local fit checks it from diverse starts

    checks.clear()
    healths.clear()
    result = diagnose(msd_fmu, data, SPEC, options=DiagnoseOptions(discriminate=False)).to_dict()
    assert set(result["absorbed"]) == {"k", "b"}
    assert checks == []
    added = list(result["added_parameters"])
    assert added and sum(set(added) <= set(names) for names, _ in healths) >= 1
    assert len(set(healths)) == len(healths)  # the profile after reused the added ones' check
    for entry in result["absorbed"].values():
        lo, hi = entry["before"]["ci"]
        assert lo < entry["before"]["estimate"] < hi
