"""A design result read back from its JSON (``fmuid.load_result``) is the result that was saved."""

import json
import math

import pytest

from design_cases import SMALL, space_of
from fmuid import load_result
from fmuid.estimation.result import Cost
from fmuid.experiment_design.result import DesignResult, RankedDesign
from fmuid.experiment_design.signals import Trial
from fmuid.experiment_design.verify import Verification
from fmuid.model.builtin import builtin_fmu
from fmuid.report import write_report


def saved(result, tmp_path):
    path = tmp_path / "design.json"
    path.write_text(json.dumps(result.to_dict(), allow_nan=False))
    return path


def test_a_computed_design_reads_back_equal(serial, tmp_path):
    back = load_result(saved(serial, tmp_path))
    assert isinstance(back, DesignResult)
    assert back.to_dict() == json.loads(json.dumps(serial.to_dict()))
    assert back.input_name == serial.input_name
    # saved with three significant digits, as the report prints them
    assert back.stage_seconds == pytest.approx(serial.stage_seconds, rel=5e-3, abs=1e-3)
    for before, after in zip(serial.designs, back.designs, strict=True):
        assert after.trial.label == before.trial.label
        assert after.score == pytest.approx(before.score, rel=1e-12)
        if before.verified is not None:
            for name in before.verified.widths:
                assert after.verified.median_width(name) == before.verified.median_width(name)
    assert back.to_frame().equals(serial.to_frame())


def test_open_intervals_unverified_designs_and_non_finite_numbers_read_back(tmp_path):
    trial = Trial("chirp", {"f0": 0.1, "f1": 1.2, "amplitude": 0.17}, 30.0, 10.0, ("x",), {"m": 2})
    verified = Verification(
        draws=3,
        identifiable={"k1": 1, "k2": 3},
        open_ended={"k1": 2, "k2": 0},
        widths={"k1": [0.5, 0.7, 0.9], "k2": [0.1, 0.3, 0.2]},
        simulations=40,
        seconds=1.5,
    )
    result = DesignResult(
        fmu_sha256="ab" * 32,
        model_name="msd_parallel",
        input_name="f",
        criterion="E",
        designs=(
            RankedDesign(
                trial,
                0.25,
                {
                    "k1": {"ci": [None, None], "status": "structurally_non_identifiable"},
                    "k2": {"ci": [0.5, 2.5], "status": "identifiable", "width_z": 0.7},
                },
                verified,
            ),
            RankedDesign(
                trial.with_(rate_hz=5.0),
                math.inf,
                {
                    "k2": {
                        "ci": [0.4, None],
                        "status": "practically_non_identifiable",
                        "width_z": math.inf,
                    }
                },
            ),
        ),
        not_identifiable_by_any=[{"parameters": ["k1", "k2"], "meaning": "only k1 + k2"}],
        tradeoffs={"drop x": {"score_ratio": None}},
        screened=12,
        cost=Cost(120, 3.25),
        stage_seconds={"screen_seconds": 1.0, "verify_seconds": 2.25},
    )
    back = load_result(saved(result, tmp_path))
    assert back.to_dict() == json.loads(json.dumps(result.to_dict(), allow_nan=False))
    first, second = back.designs
    assert first.predicted["k1"] == {"ci": [None, None], "status": "structurally_non_identifiable"}
    assert first.verified.median_width("k1") == pytest.approx(0.7)
    assert first.verified.identifiable == {"k1": 1, "k2": 3}
    assert second.verified is None and math.isnan(second.score)
    assert math.isnan(second.predicted["k2"]["width_z"])
    assert second.trial.fixed == {"m": 2.0} and second.trial.rate_hz == 5.0
    assert back.cost == Cost(120, 3.25)


def test_a_design_json_missing_a_field_is_refused_with_its_name(tmp_path):
    path = tmp_path / "design.json"
    path.write_text(json.dumps({"designs": [], "fmu": {"sha256": "x", "model_name": "m"}}))
    with pytest.raises(Exception, match="criterion"):
        load_result(path)


def test_a_design_read_back_draws_the_report_of_the_computed_one(serial, msd_spec, tmp_path):
    back = load_result(saved(serial, tmp_path))
    pages = []
    for name, result in (("computed", serial), ("read", back)):
        out = tmp_path / name
        write_report(
            result, out, fmu=builtin_fmu("msd"), experiments=[space_of(**SMALL)], spec=msd_spec
        )
        pages.append((out / "index.html").read_text())
    assert pages[1] == pages[0]
