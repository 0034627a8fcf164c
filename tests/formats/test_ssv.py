import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import fmuid
from fmuid.cli import main
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.errors import DataError, SpecError
from fmuid.estimation.predictor import FmuPredictor
from fmuid.formats import fmu_unit_definitions, read_ssv, with_start_values, write_ssv
from fmuid.formats.cli import write_csv
from fmuid.formats.ssv import SSC, SSV

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}
# SI exponents of msd's units, written out by hand (N = kg m s-2)
SI = {"kg": {"kg": 1}, "N/m": {"kg": 1, "s": -2}, "N.s/m": {"kg": 1, "s": -1}}


def _study(msd_fmu):
    t = np.round(np.arange(41) * 0.15, 10)
    f = np.where(t >= 0.3, 10.0, 0.0)
    x = FmuPredictor(msd_fmu, {}, ["f"]).predict(
        TRUTH, experiment_from_arrays("s.csv", t, {"f": f}), ["x"]
    )[:, 0]
    x = x + np.random.default_rng(5).normal(0.0, 0.05, t.size)
    spec = {
        "parameters": {
            "k": {"start": 3.0, "lower": 0.5, "upper": 20.0},
            "b": {"start": 1.0, "lower": 0.1, "upper": 10.0, "scale": "lin"},
        },
        "fixed": {"m": 1.1},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.05}},
        "global_search": False,
    }
    return [experiment_from_arrays("step.csv", t, {"f": f, "x": x})], spec_from_json(
        json.dumps(spec)
    )


@pytest.fixture(scope="module")
def profiled(msd_fmu):
    experiments, spec = _study(msd_fmu)
    return experiments, spec, fmuid.profile(msd_fmu, experiments, spec, workers=1)


def test_ssv_carries_values_units_and_intervals(profiled, msd_fmu, tmp_path):
    _, _, result = profiled
    path = write_ssv(result, tmp_path / "p.ssv", unit_definitions=fmu_unit_definitions(msd_fmu))
    root = ET.parse(path).getroot()
    assert root.tag == f"{{{SSV}}}ParameterSet" and root.get("version") == "2.0"
    units = {
        u.get("name"): {k: int(v) for k, v in u.find(f"{{{SSC}}}BaseUnit").attrib.items()}
        for u in root.iterfind(f"{{{SSV}}}Units/{{{SSC}}}Unit")
    }
    assert units == SI
    got = read_ssv(path)
    assert got.values == {**result.fit.estimates, "m": 1.1}
    assert got.units == {"k": "N/m", "b": "N.s/m", "m": "kg"}
    for name, prof in result.parameters.items():
        est = got.estimates[name]
        assert est.role == "free" and est.status == prof.status
        assert (est.lower, est.upper) == (prof.lower, prof.upper)
        assert est.intervals["simultaneous"] == prof.ci_simultaneous
        assert est.intervals["pointwise"] == prof.ci_pointwise
        assert est.confidence == 0.68
    assert got.estimates["b"].scale == "lin" and got.estimates["k"].scale == "log"
    assert got.estimates["m"].role == "fixed"
    assert got.study["model"] == "msd" and float(got.study["chi2"]) == result.chi2


def test_ssv_start_values_give_the_same_fit(profiled, msd_fmu, tmp_path):
    experiments, spec, result = profiled
    path = write_ssv(result.fit, tmp_path / "fit.ssv")
    started = with_start_values(spec, read_ssv(path).values, str(path))
    assert {n: p.start for n, p in started.parameters.items()} == result.fit.estimates
    assert started.fixed == spec.fixed
    refit = fmuid.fit(msd_fmu, experiments, started)
    assert refit.chi2 <= result.chi2 * (1 + 1e-9)
    for name, value in result.fit.estimates.items():
        assert refit.estimates[name] == pytest.approx(value, rel=1e-5)


def test_start_value_outside_the_bounds_names_file_and_parameter(profiled):
    _, spec, _ = profiled
    with pytest.raises(SpecError, match=r"p\.ssv.*start"):
        with_start_values(spec, {"k": 50.0}, "p.ssv")
    with pytest.raises(SpecError, match="free parameter 'k' needs a number"):
        with_start_values(spec, {"k": "stiff"}, "p.ssv")


def test_a_diagnosis_is_not_a_parameter_set(tmp_path):
    with pytest.raises(DataError, match="parameter 'k' has no estimate"):
        write_ssv({"parameters": {"k": {"before": 1.0, "after": 2.0}}}, tmp_path / "d.ssv")


def test_not_an_ssv_file(tmp_path):
    bad = tmp_path / "x.ssv"
    bad.write_text("<root/>")
    with pytest.raises(DataError, match="not ssv:ParameterSet"):
        read_ssv(bad)


def test_cli_exports_a_fit_and_starts_from_it(profiled, msd_fmu, tmp_path, capsys):
    experiments, spec, result = profiled
    (tmp_path / "spec.json").write_text(spec.model_dump_json(exclude_none=True))
    data = write_csv(experiments[0], tmp_path / "step.csv")
    args = ["--fmu", str(msd_fmu), "--data", str(data), "--spec", str(tmp_path / "spec.json")]
    assert main(["fit", *args, "--out", str(tmp_path / "r.json")]) == 0
    ssv = tmp_path / "r.ssv"
    assert (
        main(
            ["export-ssv", "--result", str(tmp_path / "r.json"), "--fmu", "msd", "--out", str(ssv)]
        )
        == 0
    )
    assert read_ssv(ssv).units["k"] == "N/m"
    assert main(["fit", *args, "--start", str(ssv), "--out", str(tmp_path / "r2.json")]) == 0
    first, second = (json.loads((tmp_path / n).read_text()) for n in ("r.json", "r2.json"))
    assert second["chi2"] <= first["chi2"] * (1 + 1e-9)
    assert second["units"] == {"k": "N/m", "b": "N.s/m", "m": "kg", "f": "N", "x": "m"}
    capsys.readouterr()
