"""Settle-in window and held-out validation, against scipy solutions of the mass-spring-damper."""

import functools
import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import fmuid
from fmuid.cli import main
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.errors import DataError
from fmuid.estimation.validation import held_out_rms
from fmuid.stages import make_problem

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}
T = np.round(np.arange(0.0, 20.0 + 1e-9, 0.05), 10)


def force(t):
    return 10.0 * np.sin(1.3 * t) + 6.0 * np.sin(3.1 * t)


@functools.cache
def msd_x(x0=0.0, m=1.1, k=4.4, b=1.6):
    """Position at T of m x'' + b x' + k x = f from x(0) = x0 at rest, f linear between samples."""
    samples = force(T)
    sol = solve_ivp(
        lambda tt, y: [y[1], (np.interp(tt, T, samples) - b * y[1] - k * y[0]) / m],
        (0.0, T[-1]),
        [x0, 0.0],
        t_eval=T,
        rtol=1e-10,
        atol=1e-12,
        max_step=0.05,
    )
    return sol.y[0]


def experiment(name, x, t):
    return experiment_from_arrays(name, t, {"f": force(t), "x": x})


def spec(**extra):
    body = {
        "parameters": {
            n: {"start": v * 1.1, "lower": 0.01, "upper": 10.0} for n, v in TRUTH.items()
        },
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.01}},
        "global_search": False,
        **extra,
    }
    return spec_from_json(json.dumps(body))


def test_settle_leaves_the_start_out_of_the_likelihood(msd_fmu):
    # the record starts from x = 3 m; the FMU starts at rest at 0, the transient decays in ~10 s
    noise = np.random.default_rng(0).normal(0.0, 0.01, T.size)
    data = experiment("start.csv", msd_x(3.0) + noise, T)
    fit = fmuid.fit(msd_fmu, [data], spec(settle=12.0))
    assert fit.n_data == int(np.sum(T >= 12.0))
    for name, value in TRUTH.items():
        assert fit.estimates[name] == pytest.approx(value, rel=0.01)
    assert fit.chi2 / fit.n_data < 1.5


def test_settle_is_validated():
    with pytest.raises(Exception, match="settle"):
        spec(settle=-1.0)


@pytest.mark.slow
def test_held_out_rms_is_the_simulation_error_after_the_settle_window(msd_fmu):
    x_test = msd_x(0.5)
    test = experiment("test.csv", x_test, T)
    problem = make_problem(msd_fmu, [experiment("est.csv", msd_x(), T)], spec())
    wrong = {"m": 1.0, "k": 4.4, "b": 1.6}
    model = msd_x(m=1.0)
    kept = T >= 5.0
    expected = np.sqrt(np.mean((x_test[kept] - model[kept]) ** 2))
    (entry,) = held_out_rms(problem.predictor, wrong, [test], ["x"], settle=5.0)
    assert (entry.experiment, entry.output, entry.n) == ("test.csv", "x", int(kept.sum()))
    assert entry.rms_base == pytest.approx(expected, rel=1e-4)
    assert entry.to_dict() == {
        "experiment": "test.csv",
        "output": "x",
        "n": entry.n,
        "rms_base": entry.rms_base,
    }
    steps = entry.with_steps([entry.rms_base, 0.5 * entry.rms_base]).to_dict()
    assert steps["rms_final"] == steps["rms_by_step"][-1] == 0.5 * entry.rms_base


def test_fit_reports_the_validation_of_each_test_file(msd_fmu):
    data = experiment("est.csv", msd_x(), T)
    tests = [experiment("a.csv", msd_x(), T), experiment("b.csv", msd_x() + 0.02, T)]
    result = fmuid.fit(msd_fmu, [data], spec(), test_data=tests).to_dict()
    a, b = result["validation"]
    assert (a["experiment"], b["experiment"]) == ("a.csv", "b.csv")
    assert a["rms_base"] < 1e-5
    assert b["rms_base"] == pytest.approx(0.02, rel=1e-3)
    assert "validation" not in fmuid.fit(msd_fmu, [data], spec()).to_dict()


def test_a_bad_test_file_gets_the_data_error(msd_fmu):
    data = experiment("est.csv", msd_x(), T)
    no_output = experiment_from_arrays("bad.csv", T, {"f": force(T)})
    with pytest.raises(DataError, match="bad.csv"):
        fmuid.fit(msd_fmu, [data], spec(), test_data=[no_output])
    stranger = experiment_from_arrays("odd.csv", T, {"f": force(T), "x": msd_x(), "z": T})
    with pytest.raises(DataError, match="odd.csv.*z"):
        fmuid.fit(msd_fmu, [data], spec(), test_data=[stranger])


def test_cli_takes_test_data_and_settle(msd_fmu, tmp_path, capsys):
    rows = "\n".join(f"{t:.2f},{f:.9f},{x:.9f}" for t, f, x in zip(T, force(T), msd_x(0.5)))
    data = tmp_path / "est.csv"
    data.write_text("time,f,x\n" + rows + "\n")
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps(spec().model_dump()))
    out = tmp_path / "fit.json"
    args = [
        "fit",
        "--fmu",
        msd_fmu,
        "--data",
        data,
        "--spec",
        spec_file,
        "--out",
        out,
        "--settle",
        "10",
        "--test-data",
        data,
    ]
    assert main([str(a) for a in args]) == 0, capsys.readouterr().err
    result = json.loads(out.read_text())
    assert result["n_data"] == int(np.sum(T >= 10.0))
    (entry,) = result["validation"]
    assert entry["n"] == result["n_data"]
    assert entry["rms_base"] < 1e-4
    with pytest.raises(SystemExit):
        main([str(a) for a in [*args[:-4], "--settle", "-1"]])


@pytest.mark.slow
def test_profile_reports_the_validation_at_its_best_fit(msd_fmu):
    data = experiment("est.csv", msd_x(), T)
    test = experiment("b.csv", msd_x() + 0.02, T)
    result = fmuid.profile(msd_fmu, [data], spec(), test_data=[test], workers=1).to_dict()
    (entry,) = result["validation"]
    assert entry["experiment"] == "b.csv"
    assert entry["rms_base"] == pytest.approx(0.02, rel=1e-3)
