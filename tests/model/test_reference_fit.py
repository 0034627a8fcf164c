"""Fits and profiles through foreign FMUs: VanDerPol's ``mu`` (model exchange against the exact
ODE, FMI 3.0 co-simulation against FMI 2.0), and Integer/Boolean variables in a study."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar
from scipy.stats import chi2 as chi2_dist

import fmuid
from fmuid.data import Experiment, experiment_from_arrays, spec_from_json
from fmuid.errors import SpecError
from fmuid.stages import make_problem

from .foreign import model_exchange_only, reference_fmu

MU = 1.3
SIGMA = 0.02
T = np.round(np.arange(0.0, 10.0 + 1e-9, 0.2), 10)


def _van_der_pol(mu: float) -> np.ndarray:
    sol = solve_ivp(
        lambda _, x: [x[1], mu * (1 - x[0] ** 2) * x[1] - x[0]],
        (0, T[-1]),
        [2.0, 0.0],
        t_eval=T,
        rtol=1e-12,
        atol=1e-12,
        method="DOP853",
    )
    return sol.y[0]


@pytest.fixture(scope="module")
def vdp_data() -> Experiment:
    noise = np.random.default_rng(1).normal(0.0, SIGMA, T.size)
    return experiment_from_arrays("vdp.csv", T, {"x0": _van_der_pol(MU) + noise})


def _spec() -> fmuid.data.Spec:
    body = {
        "parameters": {"mu": {"start": 1.0, "lower": 0.2, "upper": 4.0}},
        "outputs": {"x0": {"sigma": SIGMA}},
        "global_search": False,
    }
    return spec_from_json(json.dumps(body))


def _scipy_interval(data: Experiment) -> tuple[float, float]:
    """The pointwise 68 % interval of mu from the exact ODE (independent of fmuid)."""

    def chi2(mu: float) -> float:
        return float(np.sum(((data.columns["x0"] - _van_der_pol(mu)) / SIGMA) ** 2))

    best = minimize_scalar(chi2, bounds=(0.5, 2.5), method="bounded", options={"xatol": 1e-7})
    level = best.fun + chi2_dist.ppf(0.68, 1)
    lower = brentq(lambda m: chi2(m) - level, best.x - 0.5, best.x, xtol=1e-9)
    upper = brentq(lambda m: chi2(m) - level, best.x, best.x + 0.5, xtol=1e-9)
    return lower, upper


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_van_der_pol_model_exchange_interval_is_right(
    version: str, vdp_data: Experiment, tmp_path: Path
) -> None:
    if version == "fmi2":
        path = reference_fmu("fmi2", "VanDerPol_ME_only")
    else:
        path = model_exchange_only(reference_fmu("fmi3", "VanDerPol"), tmp_path / "me.fmu")
    result = fmuid.profile(path, [vdp_data], _spec(), workers=1)
    low, high = result.parameters["mu"].ci_pointwise
    assert low is not None and high is not None
    assert low < MU < high
    ref_low, ref_high = _scipy_interval(vdp_data)
    half = (ref_high - ref_low) / 2
    assert abs(low - ref_low) < 0.02 * half
    assert abs(high - ref_high) < 0.02 * half


def test_fmi3_co_simulation_gives_the_fmi2_interval(vdp_data: Experiment) -> None:
    results = [
        fmuid.profile(reference_fmu(v, "VanDerPol"), [vdp_data], _spec(), workers=1)
        for v in ("fmi2", "fmi3")
    ]
    two, three = (r.parameters["mu"] for r in results)
    np.testing.assert_allclose(three.ci_pointwise, two.ci_pointwise, rtol=1e-9)
    np.testing.assert_allclose(three.estimate, two.estimate, rtol=1e-9)


def test_integer_and_boolean_columns_in_a_fit() -> None:
    path = reference_fmu("fmi2", "Feedthrough")
    t = np.round(np.arange(0.0, 2.0 + 1e-9, 0.1), 10)
    steps = np.where(t < 1.0, 2.0, 5.0)
    columns = {
        "Int32_input": steps,
        "Int32_output": steps,
        "Boolean_input": (t >= 0.5).astype(float),
        "Boolean_output": (t >= 0.5).astype(float),
        "Float64_continuous_input": t,
        "Float64_continuous_output": t,
    }
    data = experiment_from_arrays("types.csv", t, columns)
    body = {
        "parameters": {"Float64_tunable_parameter": {"start": 1.0, "lower": 0.0, "upper": 2.0}},
        "fixed": {"Float64_fixed_parameter": 3.0},
        "outputs": {o: {"sigma": 0.1} for o in columns if o.endswith("output")},
        "global_search": False,
    }
    fit = fmuid.fit(path, [data], spec_from_json(json.dumps(body)))
    assert fit.chi2 == pytest.approx(0.0, abs=1e-18)
    assert fit.to_dict()["fmu"]["input_handling"].startswith("co-simulation, linear inputs held")
    body["parameters"] = {"Int32_input": {"start": 1, "lower": 0, "upper": 2}}
    with pytest.raises(SpecError, match="no parameter 'Int32_input'"):
        make_problem(path, [data], spec_from_json(json.dumps(body)))


def test_wrong_types_in_a_spec_are_named() -> None:
    path = reference_fmu("fmi3", "Feedthrough")
    t = np.array([0.0, 1.0])
    data = experiment_from_arrays("d.csv", t, {"Float64_continuous_output": t})
    body = {
        "parameters": {"Float64_tunable_parameter": {"start": 1.0, "lower": 0.0, "upper": 2.0}},
        "fixed": {"Float64_fixed_parameter": "text"},
        "outputs": {"Float64_continuous_output": {"sigma": 0.1}},
    }
    with pytest.raises(SpecError, match="'Float64_fixed_parameter' is a Float64 parameter"):
        make_problem(path, [data], spec_from_json(json.dumps(body)))


def test_cli_simulate_writes_integer_outputs_and_names_the_stop(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from fmuid.cli import main

    fmu = str(reference_fmu("fmi2", "Stair"))
    data, out = tmp_path / "stair.csv", tmp_path / "out.csv"
    data.write_text("time\n0\n1\n2.5\n9\n")
    assert main(["simulate", "--fmu", fmu, "--data", str(data), "--out", str(out)]) == 0
    assert out.read_text().split() == ["time,counter", "0,1", "1,2", "2.5,3", "9,10"]
    data.write_text("time\n0\n10\n")
    assert main(["simulate", "--fmu", fmu, "--data", str(data), "--out", str(out)]) == 2
    assert "stopped the simulation at t = 9.0 s" in capsys.readouterr().err
