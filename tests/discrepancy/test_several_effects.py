"""Two effects at once on the msd FMU (an input offset and a hardening spring), named in turn.

The data come from scipy's solution of m x'' + b x' + k x + 8 x^3 = f + 0.05 (not from the FMU);
a second record is held out. The diagnosis must add both, give intervals containing the truth,
and lower the held-out error.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.discrepancy.msd_truth import SPEC, msd_record

from fmuid.discrepancy import diagnose

CUBIC, OFFSET = -8.0, 0.05


@pytest.mark.slow
def test_an_offset_and_a_hardening_spring_are_both_named(msd_fmu: Path) -> None:
    train, test = (msd_record(n, s, OFFSET, CUBIC) for n, s in (("train.csv", 1), ("test.csv", 2)))
    result = diagnose(msd_fmu, [train], SPEC, test_data=[test]).to_dict()
    assert result["mismatch"] is True
    named = [e["effect"] for e in result["effects"]]
    assert sorted(named) == ["feedback_polynomial", "input_offset"]
    added = result["added_parameters"]
    for name, truth in (("c3_x_f", CUBIC), ("offset_f", OFFSET)):
        lo, hi = added[name]["ci"]
        assert lo <= truth <= hi and added[name]["excludes_off"]
    assert "hardening spring" in result["description"]
    assert result["location"]["levels"]["x"]["pattern"] == "odd"
    (check,) = result["validation"]
    assert check["rms_final"] < 0.5 * check["rms_base"] and len(check["rms_by_step"]) == 3
    assert result["chi2_after"] < result["chi2_before"]
