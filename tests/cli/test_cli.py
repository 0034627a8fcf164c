"""The fmuid command line: outputs, exit status 2 with a named problem, exit status 1."""

import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from tests.model.spy import FmuSpy

from fmuid.cli import main


def write(path, text):
    path.write_text(text)
    return path


def msd_csv(path, sigma=0.1, seed=0):
    t = np.arange(0.0, 10.0 + 1e-9, 0.2)
    sol = solve_ivp(
        lambda _t, y: [y[1], (40.0 - 1.6 * y[1] - 4.4 * y[0]) / 1.1],
        (0, 10),
        [0, 0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-12,
    )
    x = sol.y[0] + np.random.default_rng(seed).normal(0, sigma, t.size)
    rows = ["time,f,x"] + [f"{a:.3f},40,{b:.9f}" for a, b in zip(t, x)]
    return write(path, "\n".join(rows) + "\n")


SPEC = {
    "parameters": {
        n: {"start": v, "lower": 0.01, "upper": 5.0}
        for n, v in {"m": 1.1, "k": 4.4, "b": 1.6}.items()
    },
    "inputs": ["f"],
    "outputs": {"x": {"sigma": 0.1}},
    "global_search": False,
}


def run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_simulate_writes_every_output(msd_fmu, tmp_path, capsys):
    data = write(tmp_path / "in.csv", "time,f\n0,40\n1,40\n2,40\n")
    out = tmp_path / "y.csv"
    code, _, err = run(["simulate", "--fmu", msd_fmu, "--data", data, "--out", out], capsys)
    assert code == 0, err
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert table.dtype.names == ("time", "x", "v")
    # closed form of 1.1 x'' + 1.6 x' + 4.4 x = 40 from rest
    wn, zeta = np.sqrt(4.4 / 1.1), 1.6 / (2 * np.sqrt(4.4 * 1.1))
    wd = wn * np.sqrt(1 - zeta**2)
    t = table["time"]
    x = 40 / 4.4 * (1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t)))
    assert np.allclose(table["x"], x, atol=1e-8)


def test_fit_and_profile_write_contract_json(msd_fmu, tmp_path, capsys):
    data = msd_csv(tmp_path / "step.csv")
    spec = write(tmp_path / "spec.json", json.dumps(SPEC))
    out = tmp_path / "fit.json"
    code, stdout, err = run(
        ["fit", "--fmu", msd_fmu, "--data", data, "--spec", spec, "--out", out], capsys
    )
    assert code == 0, err
    fit = json.loads(out.read_text())
    assert fit["n_data"] == 51
    assert fit["parameters"]["k"]["estimate"] == pytest.approx(4.4, rel=0.02)
    assert "chi2" in stdout
    out = tmp_path / "profile.json"
    code, stdout, err = run(
        ["profile", "--fmu", msd_fmu, "--data", data, "--spec", spec, "--out", out, "--workers", 1],
        capsys,
    )
    assert code == 0, err
    result = json.loads(out.read_text())
    assert result["chi2"] == pytest.approx(fit["chi2"], rel=1e-6)
    assert all(p["status"] == "identifiable" for p in result["parameters"].values())


@pytest.mark.slow
def test_diagnose_writes_the_verdict_and_a_report(msd_fmu, tmp_path, capsys):
    data = msd_csv(tmp_path / "step.csv", seed=3)
    spec = write(tmp_path / "spec.json", json.dumps(SPEC))
    out = tmp_path / "diagnosis.json"
    with FmuSpy(msd_fmu) as spy:  # this process reads, opens and parses the FMU once
        code, stdout, err = run(
            [
                "diagnose",
                "--fmu",
                msd_fmu,
                "--data",
                data,
                "--spec",
                spec,
                "--out",
                out,
                "--report",
                tmp_path / "report",
            ],
            capsys,
        )
    assert spy.seen() == (1, 1, 1)
    assert code == 0, err
    result = json.loads(out.read_text())
    assert result["mismatch"] is False
    assert result["verdict"] in stdout
    # no annotation in the msd FMU: generic candidates named by its input and output (a step
    # input has two levels, so no saturation level lies inside the range it reaches)
    labels = {next(iter(c["parameters"])) for c in result["candidates"]}
    assert labels == {
        "tau_outputs",
        "delay_f",
        "tau_f",
        "offset_f",
        "gain_f",
        "dead_f",
        "bias_x",
        "gain_x",
        "max_x",
        "min_x",
        "c2_x_f",
        "c3_x_f",
        "coulomb_v_f",
    }
    page = (tmp_path / "report" / "index.html").read_text()
    assert "Verdict" in page and result["verdict"] in page


@pytest.mark.parametrize(
    ("csv", "spec_change", "needle"),
    [
        ("time,f,x\n0,40,0\n0,40,1\n", {}, "time"),
        ("time,f,x\n0,40,0\n1,40,abc\n", {}, "abc"),
        ("time,f,x\n0,40,0\n1,40,nan\n", {}, "row 3"),
        ("time,f,x,y\n0,40,0,1\n1,40,1,1\n", {}, "'y'"),
        (
            "time,f,x\n0,40,0\n1,40,1\n",
            {"parameters": {"q": {"start": 1, "lower": 0.1, "upper": 2}}},
            "'q'",
        ),
        ("time,f,x\n0,40,0\n1,40,1\n", {"confidence": 1.5}, "confidence"),
        ("time,f,x\n0,40,0\n1,40,1\n", {"outputs": {"x": {"sigma": -1}}}, "sigma"),
    ],
)
def test_bad_input_exits_2_naming_the_problem(msd_fmu, tmp_path, capsys, csv, spec_change, needle):
    data = write(tmp_path / "bad.csv", csv)
    spec = write(tmp_path / "spec.json", json.dumps({**SPEC, **spec_change}))
    code, _, err = run(
        ["fit", "--fmu", msd_fmu, "--data", data, "--spec", spec, "--out", tmp_path / "r.json"],
        capsys,
    )
    assert code == 2
    assert needle in err
    assert "Traceback" not in err
    assert not (tmp_path / "r.json").exists()


def test_missing_fmu_exits_2(tmp_path, capsys):
    data = write(tmp_path / "d.csv", "time,f\n0,1\n1,1\n")
    code, _, err = run(
        ["simulate", "--fmu", tmp_path / "nope.fmu", "--data", data, "--out", tmp_path / "y.csv"],
        capsys,
    )
    assert code == 2
    assert "nope.fmu" in err


def test_console_script_runs(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "fmuid.cli", "--help"], capture_output=True, text=True
    )
    assert proc.returncode == 0
    assert "build-fmus" in proc.stdout


def test_the_readme_python_example_takes_strings_and_builtin_names(tmp_path):
    import fmuid
    from fmuid.data import load_experiment, load_spec

    data = str(msd_csv(tmp_path / "step.csv"))
    spec = str(write(tmp_path / "spec.json", json.dumps(SPEC)))
    fit = fmuid.fit("msd", [load_experiment(data)], load_spec(spec))
    assert fit.estimates["k"] == pytest.approx(4.4, rel=0.02)
    with pytest.raises(fmuid.errors.FmuError, match="built-in model"):
        fmuid.fit("no_such_model", [load_experiment(data)], load_spec(spec))


def test_a_fit_the_fmu_fails_everywhere_exits_3(msd_fmu, tmp_path, capsys, monkeypatch):
    from fmuid.errors import FmuError
    from fmuid.estimation.problem import Problem

    def fail(self, z):
        raise FmuError("msd: fmi2DoStep returned fmi2Error", "fmi2DoStep", "fmi2Error")

    monkeypatch.setattr(Problem, "residuals", fail)
    data = msd_csv(tmp_path / "step.csv")
    spec = write(tmp_path / "spec.json", json.dumps(SPEC))
    out = tmp_path / "r.json"
    code, _, err = run(
        ["fit", "--fmu", msd_fmu, "--data", data, "--spec", spec, "--out", out], capsys
    )
    assert code == 3
    assert "the simulation failed at every trial point" in err
    assert "Traceback" not in err
    assert not out.exists()


def test_a_build_without_gcc_exits_4(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    code, _, err = run(["build-fmus", "--out", tmp_path / "out"], capsys)
    assert code == 4
    assert "gcc was not found" in err
