"""The candidate scan in two worker processes gives the diagnosis of one process."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import fmuid.engine.local as local_engine
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.discrepancy import DiagnoseOptions, diagnose

M, K, B, OFFSET, SIGMA = 1.1, 4.4, 1.6, 0.08, 0.005


def offset_record():  # type: ignore[no-untyped-def]
    """m x'' + b x' + k x = f + offset (scipy), noise added."""
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 15.0, 0.05)
    u = 0.6 * np.sin(2 * np.pi * 0.3 * t) + 0.4 * np.sin(2 * np.pi * 0.9 * t + 1.0)

    def rhs(tt: float, s: np.ndarray) -> list[float]:
        return [s[1], (np.interp(tt, t, u) + OFFSET - B * s[1] - K * s[0]) / M]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.01)
    return experiment_from_arrays(
        "offset.csv", t, {"f": u, "x": sol.y[0] + rng.normal(0, SIGMA, t.size)}
    )


OFFSET_SPEC = (
    '{"parameters": {"k": {"start": 4, "lower": 0.1, "upper": 20}, "b": {"start": 1,'
    ' "lower": 0.1, "upper": 10}}, "fixed": {"m": 1.1}, "inputs": ["f"],'
    ' "outputs": {"x": {"sigma": 0.005}}, "seed": 0, "global_search": false}'
)
SPEC = spec_from_json(OFFSET_SPEC)


def _comparable(result: dict) -> dict:  # type: ignore[type-arg]
    """A result without what differs between runs (wall time, provenance); its stages' costs.

    The stages' simulations and seconds sum to the total.
    """
    cost = result["cost"]
    stages = cost["stages"]
    assert sum(s["simulations"] for s in stages) == cost["simulations"]
    assert sum(s["seconds"] for s in stages) == pytest.approx(
        cost["seconds"], abs=1e-3 * len(stages)
    )
    out = {k: v for k, v in result.items() if k not in ("cost", "provenance")}
    per_stage = [(s["stage"], s["simulations"]) for s in stages]
    return {**out, "simulations": cost["simulations"], "stages": per_stage}


@pytest.mark.slow
def test_two_workers_give_the_same_diagnosis(
    msd_fmu: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    opened: list[int] = []
    real = local_engine.local_pool

    def recorded(workers, *args, **kwargs):  # type: ignore[no-untyped-def]
        opened.append(workers)
        return real(workers, *args, **kwargs)

    monkeypatch.setattr(local_engine, "local_pool", recorded)
    data = [offset_record()]
    results = []
    for workers in (1, 2):
        opts = DiagnoseOptions(workers=workers, absorbed=False, discriminate=False)
        results.append(_comparable(diagnose(msd_fmu, data, SPEC, options=opts).to_dict()))
    assert opened == [2]  # one pool for the scan and the profiles: its workers start once
    one, two = results
    assert one["mismatch"] and one["effect"] == "input_offset"
    assert [name for name, _ in one["stages"]] == [
        "base fit",
        "scan",
        "tests",
        "forward selection",
        "profiles",
        "ties",
        "validation",
    ]
    lo, hi = one["added_parameters"]["offset_f"]["ci"]
    assert lo <= OFFSET <= hi
    assert one == two


@pytest.mark.slow
def test_a_dask_cluster_gives_the_local_diagnosis(msd_fmu: Path) -> None:
    from distributed import Client, LocalCluster

    data = [offset_record()]
    opts = DiagnoseOptions(discriminate=False)
    local = diagnose(msd_fmu, data, SPEC, options=opts).to_dict()
    assert local["absorbed"]
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        with Client(cluster) as client:
            remote = diagnose(msd_fmu, data, SPEC, options=opts, executor=client).to_dict()
    assert _comparable(remote) == _comparable(local)
