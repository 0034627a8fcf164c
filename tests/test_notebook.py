"""The Python API as a notebook uses it, and the README's Python examples run as written."""

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

import fmuid
from fmuid.data import load_experiment, load_spec
from fmuid.plots import profile_figure
from msd_study import TRUTH

README = Path(__file__).resolve().parents[1] / "README.md"
EXAMPLES = README.parent / "examples"


@pytest.fixture
def study_dir(tmp_path, monkeypatch, built_fmus):
    monkeypatch.setenv("FMUID_FMU_DIR", str(built_fmus["msd"].parent))
    monkeypatch.chdir(tmp_path)
    for name in ("step.csv", "spec.json"):  # the shipped example files, as a clone has them
        shutil.copy(EXAMPLES / name, tmp_path / name)
    return tmp_path


def test_notebook_fit_profile_frame_plot_save_load(study_dir):
    experiments = [load_experiment("step.csv")]
    spec = load_spec("spec.json")
    fit = fmuid.fit("msd", experiments, spec)
    result = fmuid.profile("msd", experiments, spec, fit=fit, workers=1)

    table = result.to_frame()
    assert list(table.index) == ["k", "b"]
    assert list(table["unit"]) == ["N/m", "N.s/m"]
    for name, row in table.iterrows():
        p = result.parameters[name]
        assert row["estimate"] == p.estimate
        assert (row["ci_low"], row["ci_high"]) == p.ci_simultaneous
        assert (row["pw_low"], row["pw_high"]) == p.ci_pointwise
        assert row["status"] == "identifiable"
        # the values that made the data lie inside the simultaneous interval
        assert row["ci_low"] < TRUTH[name] < row["ci_high"]
        assert row["pw_low"] > row["ci_low"] and row["pw_high"] < row["ci_high"]

    fig = Figure()
    ax = fig.subplots()
    assert profile_figure(result, "k", ax=ax) is fig
    (line,) = [line for line in ax.lines if line.get_gid() == "profile"]
    assert min(line.get_ydata()) == pytest.approx(result.chi2)
    assert ax.get_xlabel() == "log10(k [N/m])"
    fig.savefig(study_dir / "k.png")
    assert (study_dir / "k.png").stat().st_size > 0

    for saved in (result, fit):
        path = study_dir / f"{type(saved).__name__}.json"
        path.write_text(json.dumps(saved.to_dict()))
        loaded = fmuid.load_result(str(path))
        assert type(loaded) is type(saved)
        assert loaded.to_dict() == saved.to_dict()
        pd.testing.assert_frame_equal(loaded.to_frame(), saved.to_frame())
    assert fit.to_frame().loc["k", "unit"] == "N/m"


def test_load_result_names_what_is_wrong(tmp_path):
    path = tmp_path / "r.json"
    path.write_text('{"hello": 1}')
    with pytest.raises(fmuid.errors.SpecError, match="not an fmuid result"):
        fmuid.load_result(path)
    path.write_text('{"chi2": 1, "parameters": {"k": {}}}')
    with pytest.raises(fmuid.errors.SpecError, match="missing key 'lower'"):
        fmuid.load_result(path)


def test_to_frame_without_pandas_says_how_to_install_it(study_dir, monkeypatch):
    import builtins

    fit = fmuid.fit("msd", [load_experiment("step.csv")], load_spec("spec.json"))
    real_import = builtins.__import__

    def no_pandas(name, *args, **kwargs):
        if name == "pandas":
            raise ImportError("No module named 'pandas'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pandas)
    with pytest.raises(ImportError, match=re.escape("pip install 'fmuid[report]'")):
        fit.to_frame()


def test_readme_python_examples_run(study_dir):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert blocks, "the README has no Python example"
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(README), "exec"), namespace)  # noqa: S102
    assert namespace["table"].loc["k", "unit"] == "N/m"
    assert [a.get_xlabel() for a in namespace["axes"]] == ["log10(k [N/m])", "log10(b [N.s/m])"]
    assert namespace["again"].to_dict() == namespace["result"].to_dict()


def test_a_diagnosis_loads_back_equal(study_dir):
    # the sensor reads 0.3 m too much: a mismatch for the catalogue to explain
    table = np.genfromtxt("step.csv", delimiter=",", names=True)
    rows = ["time,f,x"] + [
        f"{float(t)!r},40,{float(x) + 0.3!r}" for t, x in zip(table["time"], table["x"])
    ]
    Path("biased.csv").write_text("\n".join(rows) + "\n")
    diagnosis = fmuid.diagnose("msd", [load_experiment("biased.csv")], load_spec("spec.json"))
    assert diagnosis.mismatch and diagnosis.added_parameters and diagnosis.windows
    path = study_dir / "diagnosis.json"
    path.write_text(json.dumps(diagnosis.to_dict()))
    loaded = fmuid.load_result(path)
    assert type(loaded) is type(diagnosis)
    assert loaded.to_dict() == diagnosis.to_dict()
    pd.testing.assert_frame_equal(loaded.to_frame(), diagnosis.to_frame())
    frame = diagnosis.to_frame()
    assert set(frame.index) >= {"k", "b", *diagnosis.added_parameters}
    assert frame.loc["k", "unit"] == "N/m" and frame.loc["b", "unit"] == "N.s/m"


def test_the_estimation_stages_share_one_signature_shape() -> None:
    import inspect

    shapes = {}
    for name in ("fit", "profile", "diagnose"):
        params = inspect.signature(getattr(fmuid, name)).parameters.values()
        positional = [p.name for p in params if p.kind is p.POSITIONAL_OR_KEYWORD]
        assert positional == ["fmu", "experiments", "spec"], name
        shapes[name] = {p.name for p in params if p.kind is p.KEYWORD_ONLY}
    assert shapes["fit"] <= shapes["profile"] <= shapes["diagnose"]
