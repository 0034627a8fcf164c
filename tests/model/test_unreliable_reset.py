"""FMUs whose reset is unreliable: detected (first run, health check), then a fresh instance per
run in a simulation process replaced every FMUID_RECYCLE_RUNS runs.

The test FMU (``fmus_src/leaky_reset``) is the msd physics built from our FMI layer with two
exporter bugs: ``fmi2Reset`` keeps a growing force offset, and the library gives out at most
40 instances per process.
"""

from __future__ import annotations

import json
import multiprocessing
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar
from scipy.stats import chi2 as chi2_dist

import fmuid
from fmuid.data import Experiment, experiment_from_arrays, spec_from_json
from fmuid.errors import FmuError
from fmuid.estimation.optimize import jacobian
from fmuid.estimation.problem import Problem
from fmuid.model.build import build_fmu
from fmuid.model.builtin import model_src_dir
from fmuid.model.host import HostedSimulator
from fmuid.model.registry import fmu_summary, get_simulator
from fmuid.model.simulator import Simulator
from fmuid.profiling.health import check_health

T = np.round(np.arange(0.0, 5.0 + 1e-9, 0.1), 10)
M, B, SIGMA = 1.1, 1.6, 0.005
LIMIT = 40  # instances per process (model.c)


def _msd(k: float) -> np.ndarray:
    """Position of m x'' + b x' + k x = 1 from rest (scipy, independent of the FMU)."""
    sol = solve_ivp(
        lambda _, s: [s[1], (1.0 - B * s[1] - k * s[0]) / M],
        (0, T[-1]),
        [0, 0],
        t_eval=T,
        rtol=1e-11,
        atol=1e-13,
        method="DOP853",
    )
    return sol.y[0]


@pytest.fixture
def fresh_copy(leaky_reset_fmu: Path, tmp_path: Path) -> Path:
    """A copy at a new path: its own simulators and reset verdict."""
    return Path(shutil.copy(leaky_reset_fmu, tmp_path / "leaky_reset.fmu"))


def _run(sim: Simulator | HostedSimulator, k: float, **fixed: float) -> np.ndarray:
    ones = np.ones(T.size)
    return sim.simulate({"k": k, **fixed}, T, {"f": ones}, T, ["x"])[:, 0]


def test_in_process_detects_the_reset_and_meets_the_instance_limit(fresh_copy: Path) -> None:
    sim = Simulator(fresh_copy)
    np.testing.assert_allclose(_run(sim, 4.4), _msd(4.4), atol=1e-8)
    assert sim.reset_reliable is False  # the run after a reset had the offset
    for _ in range(LIMIT - 1):  # fresh instances: right, until the library gives out
        np.testing.assert_allclose(_run(sim, 4.4), _msd(4.4), atol=1e-8)
    with pytest.raises(FmuError, match="fmi2Instantiate"):
        _run(sim, 4.4)
    sim.close()


def test_hosted_runs_are_right_past_the_limit(
    fresh_copy: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FMUID_RECYCLE_RUNS", "12")
    ks = np.linspace(2.0, 6.0, 2 * LIMIT)
    for k in ks:  # first run in-process (detects), the rest hosted
        np.testing.assert_allclose(_run(get_simulator(fresh_copy), k), _msd(k), atol=1e-8)
    sim = get_simulator(fresh_copy)
    assert isinstance(sim, HostedSimulator)
    assert sim.processes == -(-(ks.size - 1) // 12)
    assert fmu_summary(fresh_copy)["instances"].endswith("replaced every 12 runs")
    monkeypatch.setenv("FMUID_RECYCLE_RUNS", "0")
    with pytest.raises(fmuid.errors.FmuidError, match="FMUID_RECYCLE_RUNS='0'"):
        HostedSimulator(fresh_copy)


def _data(k: float = 4.4) -> Experiment:
    noise = np.random.default_rng(5).normal(0.0, SIGMA, T.size)
    return experiment_from_arrays("step.csv", T, {"f": np.ones(T.size), "x": _msd(k) + noise})


def _spec(**fixed: float) -> fmuid.data.Spec:
    body = {
        "parameters": {"k": {"start": 3.0, "lower": 0.5, "upper": 20.0}},
        "fixed": fixed,
        "outputs": {"x": {"sigma": SIGMA}},
        "global_search": False,
    }
    return spec_from_json(json.dumps(body))


def test_health_check_finds_a_late_leak(fresh_copy: Path) -> None:
    """With delay = 3 the first-run check passes; the health check still finds the leak."""
    problem = Problem(fresh_copy, [_data()], _spec(delay=3.0))
    z = problem.to_z({"k": 4.4})
    for _ in range(6):  # a fit's worth of reset runs: the later ones carry the offset
        problem.residuals(z)
    assert get_simulator(fresh_copy).reset_reliable is True  # the first-run check passed
    health = check_health(problem, z, jacobian(problem, z))
    assert health.reset_matches_fresh is False
    assert health.deterministic and health.smooth  # measured on fresh instances
    sim = get_simulator(fresh_copy)
    assert isinstance(sim, HostedSimulator)
    np.testing.assert_allclose(_run(sim, 4.4, delay=3.0), _msd(4.4), atol=1e-8)


def _scipy_interval(data: Experiment) -> tuple[float, float]:
    """Pointwise 68 % interval of k from scipy's solution (independent of fmuid)."""
    y = data.columns["x"]

    def chi2(k: float) -> float:
        return float(np.sum(((y - _msd(k)) / SIGMA) ** 2))

    best = minimize_scalar(chi2, bounds=(3.0, 6.0), method="bounded", options={"xatol": 1e-9})
    level = best.fun + chi2_dist.ppf(0.68, 1)
    return (
        brentq(lambda k: chi2(k) - level, 3.0, best.x, xtol=1e-10),
        brentq(lambda k: chi2(k) - level, best.x, 6.0, xtol=1e-10),
    )


def test_profile_with_recycled_workers(fresh_copy: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FMUID_RECYCLE_RUNS", "15")
    data = _data()
    result = fmuid.profile(fresh_copy, [data], _spec(), workers=2)
    lo, hi = _scipy_interval(data)
    got = result.parameters["k"].ci_pointwise
    assert got == pytest.approx((lo, hi), abs=2e-3 * (hi - lo) / 2)
    out = result.to_dict()
    assert out["checks"]["health"]["reset_matches_fresh"] is False
    assert out["fmu"]["instances"].endswith("replaced every 15 runs")
    assert result.cost.simulations > LIMIT  # more runs than one process could give


def test_a_crash_in_the_simulation_process_is_an_fmu_error(tmp_path: Path) -> None:
    """The FMU kills its simulation process: an FmuError, and the next run gets a new one."""
    source = Path(__file__).parents[1] / "api" / "fmus_src" / "crash_step"
    crashing = build_fmu(model_src_dir(), source, tmp_path)
    sim = HostedSimulator(crashing, runs_per_process=100)
    zeros, ones = np.zeros(T.size), np.ones(T.size)
    with pytest.raises(FmuError, match=r"process died during a run \(signal SIGSEGV\)"):
        sim.simulate({}, T, {"f": ones}, T, ["x"])
    assert sim.simulate({}, T, {"f": zeros}, T, ["x"])[-1, 0] == 0.0  # at rest without force
    assert sim.processes == 2
    sim.close()


def _hosted_runs(path: Path, out: Any) -> None:
    sim = HostedSimulator(path, runs_per_process=2)
    out.put([_run(sim, k) for k in (3.0, 4.4, 5.0)] + [sim.processes])
    sim.close()


def test_hosted_in_a_daemonic_process(leaky_reset_fmu: Path) -> None:
    """Dask workers are daemonic processes, which multiprocessing lets start no children."""
    ctx = multiprocessing.get_context("fork")
    out = ctx.Queue()
    worker = ctx.Process(target=_hosted_runs, args=(leaky_reset_fmu, out), daemon=True)
    worker.start()
    *runs, processes = out.get(timeout=120)
    worker.join()
    assert worker.exitcode == 0 and processes == 2
    for k, y in zip((3.0, 4.4, 5.0), runs):
        np.testing.assert_allclose(y, _msd(k), atol=1e-8)
