"""A diagnosis written by an earlier version (old effect and parameter names) still loads."""

from __future__ import annotations

import json
from pathlib import Path

from fmuid.results import load_result

OLD = {
    "mismatch": True,
    "effect": "sensor_lag",
    "description": "...",
    "chi2_before": 640.2,
    "chi2_after": 101.0,
    "lrt_p_value": 1e-12,
    "second_effect": "steer_offset",
    "candidates": [
        {
            "effect": "gyro_bias",
            "parameters": {"bias_gam_t": 0.1},
            "chi2": 90.0,
            "p_value": 0.1,
            "bic": 95.0,
        }
    ],
    "added_parameters": {
        "tau_sensor": {
            "estimate": 0.12,
            "ci": [0.1, 0.14],
            "confidence": 0.95,
            "unit": "s",
            "off": 0.0,
            "excludes_off": True,
        }
    },
    "parameters": {"C_atf": {"before": 1.8e5, "after": 2.2e5}},
    "indistinguishable": [{"effect": "steering_lag", "parameters": {"tau_steer": 0.1}}],
}


def test_old_names_read_as_todays(tmp_path: Path) -> None:
    path = tmp_path / "old.json"
    path.write_text(json.dumps(OLD))
    d = load_result(path)
    assert d.effect == "output_lag" and d.second_effect == "input_offset"
    assert set(d.added_parameters) == {"tau_outputs"}
    assert d.candidates[0].effect == "output_bias"
    assert d.indistinguishable[0].parameters == {"tau_delta": 0.1}
    doc = d.to_dict()
    assert doc["verdict"].startswith("output_lag explains the mismatch")
    assert doc["effects"] == [] and doc["validation"] == []
    assert load_result(path).to_dict() == doc
