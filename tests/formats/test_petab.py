import csv
import json

import numpy as np
import pytest
import yaml

import fmuid
from fmuid.cli import main
from fmuid.data import experiment_from_arrays, load_experiment, load_spec, spec_from_json
from fmuid.errors import SpecError
from fmuid.estimation.predictor import FmuPredictor
from fmuid.formats import read_petab, write_petab

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}


def _experiment(msd_fmu, name, seed, every):
    """Force sampled every 0.05 s, x and v only every ``every``-th row (empty cells between)."""
    t = np.round(np.arange(121) * 0.05, 10)
    f = 8.0 * np.sin(2 * np.pi * 0.4 * t) + np.where(t > 1.0, 3.0, 0.0)
    y = FmuPredictor(msd_fmu, {}, ["f"]).predict(
        TRUTH, experiment_from_arrays(name, t, {"f": f}), ["x", "v"]
    )
    rng = np.random.default_rng(seed)
    keep = np.arange(t.size) % every == 0
    sigma_v = np.where(keep, 0.05 + 0.05 * (t / t[-1]), np.nan)
    x = np.where(keep, y[:, 0] + rng.normal(0.0, 0.03, t.size), np.nan)
    v = np.where(keep, y[:, 1] + rng.normal(0.0, 1.0, t.size) * sigma_v, np.nan)
    return experiment_from_arrays(name, t, {"f": f, "x": x, "v": v, "sigma_v": sigma_v})


@pytest.fixture(scope="module")
def study(msd_fmu):
    experiments = [
        _experiment(msd_fmu, "sine.csv", 1, 3),
        _experiment(msd_fmu, "2nd run.csv", 2, 4),
    ]
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {
                    "k": {"start": 3.0, "lower": 0.5, "upper": 20.0},
                    "b": {"start": 1.0, "lower": -1.0, "upper": 10.0},
                },
                "fixed": {"m": 1.1},
                "outputs": {"x": {"sigma": 0.03}, "v": {"sigma": "column"}},
                "confidence": 0.9,
                "global_search": False,
                "seed": 4,
            }
        )
    )
    return experiments, spec


def _tsv(path):
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle, delimiter="\t"))


def test_petab_files_follow_the_mapping(study, msd_fmu, tmp_path):
    experiments, spec = study
    problem = write_petab(tmp_path / "p", msd_fmu, experiments, spec)
    config = yaml.safe_load(problem.read_text())
    assert config["format_version"] == "2.0.0"
    assert config["model_files"] == {"msd": {"location": "msd.fmu", "language": "fmu"}}
    assert (tmp_path / "p" / "msd.fmu").read_bytes() == msd_fmu.read_bytes()
    params = {r["parameterId"]: r for r in _tsv(tmp_path / "p" / "parameters.tsv")}
    assert params["k"]["parameterScale"] == "log10" and params["b"]["parameterScale"] == "lin"
    assert (params["k"]["lowerBound"], params["k"]["upperBound"]) == ("0.5", "20.0")
    assert params["k"]["estimate"] == "true"
    assert _tsv(tmp_path / "p" / "conditions.tsv") == [
        {"conditionId": "fmuid_fixed", "targetId": "m", "targetValue": "1.1"}
    ]
    obs = {r["observableId"]: r for r in _tsv(tmp_path / "p" / "observables.tsv")}
    # PEtab forbids observable ids that name a model entity: obs_<output>, formula the output
    assert set(obs) == {"obs_x", "obs_v"}
    assert obs["obs_x"]["noiseFormula"] == "0.03" and obs["obs_x"]["observableFormula"] == "x"
    assert obs["obs_v"]["noiseFormula"] == obs["obs_v"]["noisePlaceholders"]
    assert obs["obs_v"]["noisePlaceholders"] == "noiseParameter1_obs_v"
    meas = _tsv(tmp_path / "p" / "measurements.tsv")
    # 121 rows, outputs in every 3rd (41) and every 4th (31) row, two outputs each
    assert len(meas) == 2 * (41 + 31)
    assert {r["experimentId"] for r in meas} == {"sine", "e_2nd_run"}
    assert {r["observableId"] for r in meas} == {"obs_x", "obs_v"}
    inputs = _tsv(tmp_path / "p" / "inputs.tsv")
    assert len(inputs) == 2 * 121 and {r["inputId"] for r in inputs} == {"f"}


def test_petab_round_trip_same_problem_same_result(study, msd_fmu, tmp_path):
    experiments, spec = study
    back = read_petab(write_petab(tmp_path / "p", msd_fmu, experiments, spec))
    assert back.fmu.read_bytes() == msd_fmu.read_bytes()
    assert back.spec.fixed == spec.fixed
    assert back.spec.outputs == spec.outputs
    assert (back.spec.confidence, back.spec.global_search, back.spec.seed) == (0.9, False, 4)
    assert back.spec.interface == spec.interface
    for name, p in spec.parameters.items():
        q = back.spec.parameters[name]
        assert (q.start, q.lower, q.upper, q.resolved_scale) == (
            p.start,
            p.lower,
            p.upper,
            p.resolved_scale,
        )
    assert [e.name for e in back.experiments] == ["sine.csv", "2nd run.csv"]
    for a, b in zip(experiments, back.experiments, strict=True):
        np.testing.assert_array_equal(a.time, b.time)
        assert set(a.columns) == set(b.columns)
        for column in a.columns:
            np.testing.assert_array_equal(a.columns[column], b.columns[column])
    original = fmuid.fit(msd_fmu, experiments, spec)
    imported = fmuid.fit(back.fmu, back.experiments, back.spec)
    assert imported.chi2 == original.chi2
    assert imported.estimates == original.estimates
    assert imported.estimates["k"] == pytest.approx(TRUTH["k"], rel=0.05)


def test_cli_import_writes_files_that_fmuid_reads(study, msd_fmu, tmp_path, capsys):
    experiments, spec = study
    problem = write_petab(tmp_path / "p", msd_fmu, experiments, spec)
    assert main(["import-petab", "--problem", str(problem), "--out", str(tmp_path / "q")]) == 0
    assert "fmuid fit --fmu" in capsys.readouterr().out
    assert load_spec(tmp_path / "q" / "spec.json").outputs == spec.outputs
    again = load_experiment(tmp_path / "q" / "sine.csv")
    np.testing.assert_array_equal(again.columns["x"], experiments[0].columns["x"])


def test_what_fmuid_cannot_run_is_named(study, msd_fmu, tmp_path):
    experiments, spec = study
    problem = write_petab(tmp_path / "p", msd_fmu, experiments, spec)
    config = yaml.safe_load(problem.read_text())
    config["model_files"]["msd"]["language"] = "sbml"
    problem.write_text(yaml.safe_dump(config))
    with pytest.raises(SpecError, match="language 'sbml' is not 'fmu'"):
        read_petab(problem)
    config["model_files"]["msd"]["language"] = "fmu"
    problem.write_text(yaml.safe_dump(config))
    obs = tmp_path / "p" / "observables.tsv"
    obs.write_text(obs.read_text().replace("\tx\t0.03", "\t2*x\t0.03"))
    with pytest.raises(SpecError, match="observable obs_x: observableFormula '2\\*x'"):
        read_petab(problem)


def test_an_estimated_sigma_becomes_a_noise_parameter_and_back(study, msd_fmu, tmp_path):
    experiments, spec = study
    data = json.loads(spec.model_dump_json(exclude_none=True))
    data["outputs"]["x"] = {"sigma": "estimate"}
    estimated = spec_from_json(json.dumps(data))
    problem = write_petab(tmp_path / "p", msd_fmu, experiments, estimated)
    obs = {r["observableId"]: r for r in _tsv(tmp_path / "p" / "observables.tsv")}
    assert obs["obs_x"]["noiseFormula"] == "sigma_x"
    params = {r["parameterId"]: r for r in _tsv(tmp_path / "p" / "parameters.tsv")}
    assert params["sigma_x"]["estimate"] == "true"
    back = read_petab(problem)
    assert back.spec.outputs["x"].sigma == "estimate"
    assert set(back.spec.parameters) == {"k", "b"}


def test_tractor_steer_angle_sampled_faster_than_the_yaw_rates(tractor_fmu, tmp_path):
    import fieldtruth as ft
    from fmuid.stages import make_problem
    from operational import study_spec

    experiments = ft.make_case(None, seed=3, rate=5.0).experiments
    spec = study_spec()
    back = read_petab(write_petab(tmp_path / "p", tractor_fmu, experiments, spec))
    inputs = _tsv(tmp_path / "p" / "inputs.tsv")
    # delta in every row (201 + 301), the yaw rates in every other row only
    assert len(inputs) == 201 + 301 and {r["inputId"] for r in inputs} == {"delta"}
    assert len(_tsv(tmp_path / "p" / "measurements.tsv")) == 2 * (101 + 151)
    for a, b in zip(experiments, back.experiments, strict=True):
        assert set(a.columns) == set(b.columns)
        for column in a.columns:
            np.testing.assert_array_equal(a.columns[column], b.columns[column])
    original = make_problem(tractor_fmu, experiments, spec)
    imported = make_problem(back.fmu, back.experiments, back.spec)
    start = {n: p.start for n, p in spec.parameters.items()}
    assert imported.chi2(imported.to_z(start)) == original.chi2(original.to_z(start))


def _libpetab_issues(problem_yaml):
    from formats.petab_model import petab_problem

    problem = petab_problem(problem_yaml)
    return problem, [(str(i.level.name), i.message) for i in problem.validate()]


EXTENSION_WARNING = (
    "WARNING",
    "Validation of PEtab extensions is not yet implemented, but the given problem uses the "
    "following extensions: fmuid",
)


def test_libpetab_finds_no_error_in_exported_problems(study, msd_fmu, tmp_path):
    pytest.importorskip("petab.v2", reason="libpetab (petab, in the dev extra) is not installed")
    experiments, spec = study
    data = json.loads(spec.model_dump_json(exclude_none=True))
    data["outputs"]["x"] = {"sigma": "estimate"}
    for name, s in (("given", spec), ("estimated", spec_from_json(json.dumps(data)))):
        problem, issues = _libpetab_issues(write_petab(tmp_path / name, msd_fmu, experiments, s))
        assert issues == [EXTENSION_WARNING], name
        # libpetab reads the problem fmuid meant: free parameters, bounds, start values, data
        free = ["k", "b"] + (["sigma_x"] if name == "estimated" else [])
        assert problem.x_free_ids == free
        assert problem.lb[:2] == [0.5, -1.0] and problem.ub[:2] == [20.0, 10.0]
        assert problem.x_nominal[:2] == [3.0, 1.0]
        assert problem.n_measurements == 2 * (41 + 31)


def test_libpetab_rejects_an_observable_named_as_the_fmu_output(study, msd_fmu, tmp_path):
    """The adapter lets libpetab check against the FMU: the ids fmuid wrote before are caught."""
    pytest.importorskip("petab.v2", reason="libpetab (petab, in the dev extra) is not installed")
    experiments, spec = study
    problem = write_petab(tmp_path / "p", msd_fmu, experiments, spec)
    for table in ("observables.tsv", "measurements.tsv"):
        path = tmp_path / "p" / table
        path.write_text(path.read_text().replace("obs_x", "x"))
    _, issues = _libpetab_issues(problem)
    assert ("ERROR", "Observable IDs ['x'] shadow model entities.") in issues
    assert read_petab(problem).spec.outputs == spec.outputs  # fmuid still reads such files
