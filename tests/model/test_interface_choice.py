"""Choosing the FMI interface of an FMU that has both: the spec's ``interface`` and the CLI's
``--interface``, validated, and named in the result."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import fmuid
from fmuid.cli import main
from fmuid.data import Experiment, experiment_from_arrays, spec_from_json
from fmuid.errors import SpecError
from fmuid.model.fmu import model_of_file
from fmuid.model.registry import get_simulator

from .foreign import model_exchange_only, reference_fmu

T = np.round(np.arange(0.0, 6.0 + 1e-9, 0.2), 10)


def _exact() -> np.ndarray:
    """x0 of VanDerPol with mu = 1.3 from (2, 0) (scipy, independent of the FMU)."""
    sol = solve_ivp(
        lambda _, x: [x[1], 1.3 * (1 - x[0] ** 2) * x[1] - x[0]],
        (0, T[-1]),
        [2.0, 0.0],
        t_eval=T,
        rtol=1e-12,
        atol=1e-12,
        method="DOP853",
    )
    return sol.y[0]


@pytest.fixture(scope="module")
def vdp() -> Experiment:
    noise = np.random.default_rng(2).normal(0.0, 0.02, T.size)
    return experiment_from_arrays("vdp.csv", T, {"x0": _exact() + noise})


def _spec(interface: str | None) -> fmuid.data.Spec:
    body = {
        "parameters": {"mu": {"start": 1.0, "lower": 0.2, "upper": 4.0}},
        "outputs": {"x0": {"sigma": 0.02}},
        "global_search": False,
        **({"interface": interface} if interface else {}),
    }
    return spec_from_json(json.dumps(body), "vdp.json")


def test_spec_interface_chooses_model_exchange(vdp: Experiment, tmp_path: Path) -> None:
    both = reference_fmu("fmi3", "VanDerPol")
    only_me = model_exchange_only(both, tmp_path / "me.fmu")
    chosen = fmuid.fit(both, [vdp], _spec("model_exchange"))
    forced = fmuid.fit(only_me, [vdp], _spec(None))
    assert chosen.to_dict()["fmu"]["interface"] == "ModelExchange"
    assert "CVode" in chosen.to_dict()["fmu"]["input_handling"]
    assert chosen.estimates["mu"] == pytest.approx(forced.estimates["mu"], rel=1e-9)
    for interface in (None, "auto", "co_simulation"):
        fmu = fmuid.fit(both, [vdp], _spec(interface)).to_dict()["fmu"]
        assert fmu["interface"] == "CoSimulation" and "co-simulation" in fmu["input_handling"]


def test_an_interface_the_fmu_lacks_is_a_spec_error(vdp: Experiment) -> None:
    with pytest.raises(SpecError, match=r"vdp.json: interface: the FMU has no co_simulation"):
        fmuid.fit(reference_fmu("fmi2", "VanDerPol_ME_only"), [vdp], _spec("co_simulation"))
    with pytest.raises(SpecError, match=r"interface.*'auto', 'co_simulation' or 'model_exchange'"):
        _spec("cvode")


def test_cli_interface_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    both = reference_fmu("fmi2", "VanDerPol")
    data = tmp_path / "vdp.csv"
    np.savetxt(
        data, np.column_stack([T, np.zeros(T.size)]), delimiter=",", header="time,x0", comments=""
    )
    spec = tmp_path / "spec.json"
    spec.write_text(
        json.dumps(
            {
                "parameters": {"mu": {"start": 1.0, "lower": 0.2, "upper": 4}},
                "outputs": {"x0": {"sigma": 0.1}},
                "global_search": False,
            }
        )
    )
    out = tmp_path / "fit.json"
    args = ["fit", "--fmu", both, "--data", data, "--spec", spec, "--out", out]
    assert main([str(a) for a in [*args, "--interface", "model_exchange"]]) == 0
    assert json.loads(out.read_text())["fmu"]["interface"] == "ModelExchange"
    only_me = reference_fmu("fmi2", "VanDerPol_ME_only")
    sim = ["simulate", "--fmu", only_me, "--data", data, "--out", tmp_path / "y.csv"]
    assert main([str(a) for a in [*sim, "--interface", "co_simulation"]]) == 2
    assert "no co_simulation interface (it has model_exchange)" in capsys.readouterr().err
    assert main([str(a) for a in [*sim, "--interface", "model_exchange"]]) == 0
    y = np.loadtxt(tmp_path / "y.csv", delimiter=",", skiprows=1)
    assert y[0, 1] == 2.0  # VanDerPol starts at x0 = 2


def test_simulate_takes_the_interface_from_a_fixed_only_spec(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    both = reference_fmu("fmi2", "VanDerPol")
    data = tmp_path / "t.csv"
    np.savetxt(data, T, header="time", comments="")
    spec = tmp_path / "fixed.json"
    out = tmp_path / "y.csv"
    rows = {}
    for interface in ("co_simulation", "model_exchange"):
        spec.write_text(json.dumps({"fixed": {"mu": 1.3}, "interface": interface}))
        args = ["simulate", "--fmu", both, "--data", data, "--spec", spec, "--out", out]
        assert main([str(a) for a in args]) == 0
        rows[interface] = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1]
    exact = _exact()
    me_error = np.max(np.abs(rows["model_exchange"] - exact))
    assert me_error < 1e-5 < np.max(np.abs(rows["co_simulation"] - exact))  # CS: Euler steps
    spec.write_text(json.dumps({"fixed": {}, "interface": "cvode"}))
    assert (
        main(
            [
                str(a)
                for a in ["simulate", "--fmu", both, "--data", data, "--spec", spec, "--out", out]
            ]
        )
        == 2
    )
    assert "interface: 'cvode' is not one of" in capsys.readouterr().err


def test_another_interface_leaves_the_files_model_as_it_was() -> None:
    both = reference_fmu("fmi3", "VanDerPol")
    model = model_of_file(both)
    other = model.with_interface("model_exchange")
    assert (model.interface, other.interface) == ("CoSimulation", "ModelExchange")
    assert model_of_file(both) is model
    assert get_simulator(both).model.interface == "CoSimulation"
