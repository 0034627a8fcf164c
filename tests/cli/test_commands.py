"""The command line as a user types it: a fit's table, -v anywhere, --start FIT.json, fast start."""

import json
import subprocess
import sys

import pytest

from fmuid.cli import _parser, main
from msd_study import TRUTH, write_msd_study

STUDY = ["--fmu", "msd", "--data", "step.csv", "--spec", "spec.json", "--out", "r.json"]


@pytest.fixture
def study(tmp_path, monkeypatch, built_fmus):
    monkeypatch.setenv("FMUID_FMU_DIR", str(built_fmus["msd"].parent))
    monkeypatch.chdir(tmp_path)
    write_msd_study(tmp_path)
    return ["--fmu", "msd", "--data", "step.csv", "--spec", "spec.json"]


def test_fit_prints_a_table_of_estimates(study, capsys):
    assert main(["fit", *study, "--out", "fit.json"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["parameter", "estimate", "unit", "bounds"]
    rows = {line.split()[0]: line.split() for line in lines[2:4]}
    saved = json.loads(open("fit.json").read())["parameters"]
    for name, unit in (("k", "N/m"), ("b", "N.s/m")):
        assert float(rows[name][1]) == pytest.approx(saved[name]["estimate"], rel=1e-5)
        assert rows[name][2] == unit and rows[name][3] == "[0.1,"
        assert abs(float(rows[name][1]) - TRUTH[name]) < 0.2 * TRUTH[name]
    assert lines[-1].startswith("chi2 ")


def test_verbose_before_or_after_the_command():
    for argv in (["fit", *STUDY, "-v"], ["-v", "fit", *STUDY], ["info", "msd", "--verbose"]):
        assert _parser().parse_args(argv).verbose is True
    assert _parser().parse_args(["fit", *STUDY]).verbose is False


def test_start_from_an_earlier_fit_skips_the_global_search(study, capsys, caplog):
    assert main(["fit", *study, "--out", "fit.json"]) == 0
    first = json.loads(open("fit.json").read())
    caplog.set_level("INFO", logger="fmuid")
    assert main(["fit", *study, "--out", "again.json", "--start", "fit.json"]) == 0
    again = json.loads(open("again.json").read())
    assert again["global_search"] is False
    for name, p in first["parameters"].items():
        assert again["parameters"][name]["estimate"] == pytest.approx(p["estimate"], rel=1e-4)
    assert "starting at the estimates of fit.json" in caplog.text
    open("bad.json", "w").write("[1, 2]")
    assert main(["diagnose", *study, "--out", "d.json", "--start", "bad.json"]) == 2
    assert "bad.json: not a fit or profile result" in capsys.readouterr().err


def test_simulate_loads_no_optimiser_or_plotting():
    code = (
        "import sys, fmuid.cli, fmuid.stages, fmuid.estimation.predictor, fmuid.readable;"
        "print(sorted(sys.modules))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = set(eval(proc.stdout))
    assert not {"pymoo", "scipy.optimize", "scipy.stats", "matplotlib", "jinja2"} & loaded


def test_a_simulation_as_a_table(study):
    import fmuid
    from fmuid.data import load_experiment

    run = fmuid.simulate("msd", load_experiment("step.csv"), {"k": 2.0})
    frame = run.to_frame()
    assert frame.index.name == "time" and list(frame.index) == list(run.time)
    assert list(frame.columns) == [*run.inputs, *run.outputs]
    assert (frame["x"].to_numpy() == run.outputs["x"]).all()
