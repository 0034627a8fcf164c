"""FMUs from a second exporter and with an unreliable reset, uploaded to the real service: the
job's intervals equal the Python API's, and the result says how the FMU was run."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import fmuid
from api_helpers import Service
from fmuid.data import load_experiment, spec_from_json

T = np.round(np.arange(0.0, 4.0 + 1e-9, 0.1), 10)


def _csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    table = np.column_stack([T, *columns.values()])
    header = ",".join(["time", *columns])
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.17g")
    return path


def _profile_over_http(service: Service, spec: dict, csv: Path, fmu: Path) -> dict:
    client = service.client()
    job = client.submit("profile", json.dumps(spec), [csv], fmu_path=fmu)
    status = client.wait(job, timeout=600)
    assert status["status"] == "done", status
    result: dict = client.result(job)
    return result


def test_pythonfmu_profile_over_http(service: Service, first_order_fmu: Path, tmp_path: Path):
    y = 2.0 * (1 - np.exp(-T / 0.5)) + np.random.default_rng(3).normal(0, 0.02, T.size)
    csv = _csv(tmp_path / "lag.csv", {"u": np.ones(T.size), "y": y})
    spec = {
        "parameters": {
            "K": {"start": 1.0, "lower": 0.1, "upper": 10.0},
            "tau": {"start": 1.0, "lower": 0.05, "upper": 5.0},
        },
        "inputs": ["u"],
        "outputs": {"y": {"sigma": 0.02}},
        "global_search": False,
    }
    remote = _profile_over_http(service, spec, csv, first_order_fmu)
    local = fmuid.profile(
        first_order_fmu, [load_experiment(csv)], spec_from_json(json.dumps(spec)), workers=1
    )
    for name in ("K", "tau"):
        np.testing.assert_allclose(
            remote["parameters"][name]["ci"]["pointwise"],
            local.parameters[name].ci_pointwise,
            rtol=1e-6,
        )
    assert remote["fmu"]["model_name"] == "FirstOrder"
    assert "sub-steps" in remote["fmu"]["input_handling"]


@pytest.mark.slow
def test_unreliable_reset_over_http(
    service_factory: Callable[..., Service], leaky_reset_fmu: Path, msd_file: Path, tmp_path: Path
) -> None:
    """The job process hosts the FMU in simulation processes replaced every 10 runs; the
    interval equals the built-in msd's (the same physics with a working reset)."""
    _, x = msd_step_response()
    csv = _csv(tmp_path / "step.csv", {"f": np.ones(T.size), "x": x})
    spec = {
        "parameters": {"k": {"start": 3.0, "lower": 0.5, "upper": 20.0}},
        "outputs": {"x": {"sigma": 0.005}},
        "global_search": False,
    }
    service = service_factory(FMUID_RECYCLE_RUNS="10")
    remote = _profile_over_http(service, spec, csv, leaky_reset_fmu)
    assert remote["fmu"]["instances"].endswith("replaced every 10 runs")
    assert remote["checks"]["health"]["reset_matches_fresh"] is False
    assert remote["cost"]["simulations"] > 40  # more runs than one process of this FMU gives
    reliable = fmuid.profile(
        msd_file, [load_experiment(csv)], spec_from_json(json.dumps(spec)), workers=1
    )
    np.testing.assert_allclose(
        remote["parameters"]["k"]["ci"]["pointwise"],
        reliable.parameters["k"].ci_pointwise,
        rtol=1e-9,
    )


def msd_step_response() -> tuple[np.ndarray, np.ndarray]:
    """x of m x'' + b x' + k x = 1 (m, k, b = 1.1, 4.4, 1.6) from rest, plus seeded noise."""
    sol = solve_ivp(
        lambda _, s: [s[1], (1 - 1.6 * s[1] - 4.4 * s[0]) / 1.1],
        (0, T[-1]),
        [0, 0],
        t_eval=T,
        rtol=1e-11,
        atol=1e-13,
        method="DOP853",
    )
    return T, sol.y[0] + np.random.default_rng(5).normal(0, 0.005, T.size)
