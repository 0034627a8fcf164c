"""Where a study starts: ``--start`` in the CLI and ``start=`` of ``fmuid.diagnose``."""

import json

import pytest

import fmuid
from fmuid.data import load_experiment, load_spec
from fmuid.discrepancy import study as diagnose_study
from fmuid.errors import DataError
from fmuid.formats.start import start_at
from msd_study import write_msd_study


@pytest.fixture
def spec(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_msd_study(tmp_path)
    return load_spec(tmp_path / "spec.json")


def test_a_result_in_any_form_gives_its_estimates_and_no_global_search(spec, tmp_path):
    estimates = {n: (p.lower + p.upper) / 3 for n, p in spec.parameters.items()}
    saved = {"parameters": {n: {"estimate": v} for n, v in estimates.items()}}
    (tmp_path / "fit.json").write_text(json.dumps(saved))
    for start in (saved, "fit.json", tmp_path / "fit.json"):
        started = start_at(spec, start)
        assert started.global_search is False
        assert {n: p.start for n, p in started.parameters.items()} == pytest.approx(estimates)
    assert start_at(spec, None) is spec
    (tmp_path / "bad.json").write_text("[1, 2]")
    with pytest.raises(DataError, match="bad.json: not a fit or profile result"):
        start_at(spec, "bad.json")


def test_diagnose_starts_at_an_earlier_fit(spec, monkeypatch, built_fmus):
    monkeypatch.setenv("FMUID_FMU_DIR", str(built_fmus["msd"].parent))
    experiments = [load_experiment("step.csv")]
    fit = fmuid.fit("msd", experiments, spec.model_copy(update={"global_search": False}))
    seen = {}

    def stop(problem, **_):  # the problem diagnose would fit, then no more
        seen["spec"] = problem.spec
        raise KeyboardInterrupt

    monkeypatch.setattr(diagnose_study, "diagnose_problem", stop)
    with pytest.raises(KeyboardInterrupt):
        fmuid.diagnose("msd", experiments, spec, start=fit)
    assert seen["spec"].global_search is False
    starts = {n: p.start for n, p in seen["spec"].parameters.items()}
    assert starts == pytest.approx(dict(fit.estimates))
