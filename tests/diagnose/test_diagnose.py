"""End to end: concealed effects in independent field truth are flagged, named and sized."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import fieldtruth as ft
from fmuid.data import Spec, spec_from_json
from fmuid.diagnose import diagnose
from fmuid.diagnose.plots import figures
from fmuid.stages import make_problem


def _spec() -> Spec:
    return spec_from_json(
        json.dumps(
            {
                "parameters": {
                    n: {"start": ft.NOMINAL[n], "lower": lo, "upper": hi}
                    for n, (lo, hi) in ft.BOUNDS.items()
                },
                "inputs": ["delta"],
                "outputs": {"gam_t": {"sigma": "column"}, "gam_i": {"sigma": "column"}},
                "global_search": False,
            }
        )
    )


def test_control_raises_no_false_alarm(tractor_fmu: Path) -> None:
    case = ft.make_case(None, seed=11, rate=5.0)
    result = diagnose(tractor_fmu, case.experiments, _spec()).to_dict()
    assert result["mismatch"] is False
    assert result["effect"] is None
    assert result["evidence"] == []
    assert result["chi2_after"] == result["chi2_before"]
    contract = {
        "mismatch", "evidence", "location", "effect", "description", "candidates",
        "added_parameters", "chi2_before", "chi2_after", "parameters",
    }  # fmt: skip
    assert contract <= set(result)
    assert set(result["parameters"]) == set(ft.BOUNDS)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("effect", "parameter", "level"),
    [
        ("sensor_lag", "tau_sensor", 1),
        ("steer_offset", "offset_steer", 0),
        ("tire_saturation", "alpha_sat", 1),
    ],
)
def test_concealed_effect_is_named_with_ci_holding_the_truth(
    tractor_fmu: Path, effect: str, parameter: str, level: int
) -> None:
    magnitude = ft.MAGNITUDES[effect][level]
    case = ft.make_case(effect, magnitude, seed=4, rate=5.0)
    diagnosis = diagnose(tractor_fmu, case.experiments, _spec())
    result = diagnosis.to_dict()
    assert result["mismatch"] is True
    assert result["evidence"]
    assert result["effect"] == effect
    added = result["added_parameters"][parameter]
    lo, hi = added["ci"]
    assert (lo is None or lo <= magnitude) and (hi is None or magnitude <= hi)
    assert added["excludes_off"] is True
    assert result["chi2_after"] < result["chi2_before"]
    assert result["lrt_p_value"] < 0.01
    assert set(result["parameters"]) >= {*ft.BOUNDS, parameter}
    figs = figures(diagnosis, make_problem(tractor_fmu, case.experiments, _spec()))
    assert set(figs) == {"fit", "residuals", "spectrum"}
    assert all(len(f.axes) == 4 for f in figs.values())
