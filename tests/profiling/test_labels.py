"""Identifiability labels: structural only with a null direction of the sensitivities."""

import numpy as np
import pytest

import fmuid
from fmuid.demo.thesis import DESIGNS, SNRS, simulate_dataset, study_spec
from fmuid.profiling.intervals import label
from fmuid.profiling.result import (
    IDENTIFIABLE,
    PRACTICALLY_NON_IDENTIFIABLE,
    STRUCTURALLY_NON_IDENTIFIABLE,
)


def test_flat_without_null_direction_is_practical():
    status, reason = label("sig_ir", True, (None, None), ("bound", "bound"), None)
    assert status == PRACTICALLY_NON_IDENTIFIABLE
    assert "full rank" in reason


def test_flat_with_null_direction_is_structural():
    status, reason = label(
        "k1", True, (None, None), ("", ""), ["k2"], "only k1 + k2 is identifiable"
    )
    assert status == STRUCTURALLY_NON_IDENTIFIABLE
    assert "k2" in reason and "k1 + k2" in reason


def test_open_end_says_which_side_and_why():
    status, reason = label("C_air", False, (1.0, None), ("", "bound"), None)
    assert status == PRACTICALLY_NON_IDENTIFIABLE
    assert "above the estimate (up to the bound)" in reason
    assert label("C_air", False, (1.0, 2.0), ("", ""), None)[0] == IDENTIFIABLE


@pytest.mark.slow
@pytest.mark.parametrize("snr", [25.0, 16.67])
def test_demo_chirp_low_snr_has_no_structural_label(tractor_fmu, snr):
    """Both yaw rates make the tractor structurally identifiable (thesis Ch. 3.4)."""
    design = DESIGNS[2]
    rng = np.random.default_rng((0, DESIGNS.index(design), SNRS.index(snr)))
    experiment, sigma = simulate_dataset(tractor_fmu, design, snr, rng)
    result = fmuid.profile(tractor_fmu, [experiment], study_spec(sigma), workers=2)
    assert result.structural_check["non_identifiable_combinations"] == []
    for name, p in result.parameters.items():
        assert p.status != STRUCTURALLY_NON_IDENTIFIABLE, (name, p.status_reason)
        assert p.status_reason
