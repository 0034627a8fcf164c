"""The generic ARX correction separates input-driven structure from noise."""

from __future__ import annotations

import numpy as np

from fmuid.diagnose.correction import arx_correction
from fmuid.diagnose.residual_tests import Series


def _series(extra: float, seed: int) -> Series:
    rng = np.random.default_rng(seed)
    t = np.arange(200) * 0.1
    u = np.sin(2 * np.pi * (0.1 * t + 0.02 * t**2))
    r = rng.normal(size=len(t)) + extra * np.concatenate([np.zeros(3), u[:-3]])
    return Series("chirp.csv", "gam_t", t, r, {"delta": u})


def test_noise_alone_is_not_structure() -> None:
    out = arx_correction([_series(0.0, 0)])
    assert out["p_value"] > 0.01
    assert out["chi2_after"] >= 0.8 * out["noise_chi2"]


def test_input_driven_error_is_structure_down_to_the_noise() -> None:
    out = arx_correction([_series(3.0, 1)])
    assert out["p_value"] < 1e-10
    assert out["structure_fraction"] > 0.7
    assert out["chi2_after"] < 1.3 * out["noise_chi2"]
