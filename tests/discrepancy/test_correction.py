"""The generic ARX correction separates input-driven structure from noise."""

from __future__ import annotations

import numpy as np

from fmuid.discrepancy.correction import arx_correction
from fmuid.discrepancy.residual_tests import Series


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
    assert out["chi2_after"] < 1.3 * out["noise_chi2"]
    share = out["structure_fraction"]
    if out["chi2_after"] < out["noise_chi2"]:
        assert share is None  # below the noise floor no share is given
    else:
        assert share > 0.7


def test_an_extra_mode_is_found_with_its_frequency_and_damping() -> None:
    # residual = a lightly damped second-order response to the input (closed-form poles)
    dt, f0, zeta = 0.1, 0.5, 0.1
    w0 = 2 * np.pi * f0
    s = complex(-zeta * w0, w0 * np.sqrt(1 - zeta**2))
    z = np.exp(s * dt)
    a1, a2 = 2 * z.real, -(abs(z) ** 2)
    rng = np.random.default_rng(3)
    t = np.arange(600) * dt
    u = rng.normal(size=len(t))
    y = np.zeros(len(t))
    for k in range(2, len(t)):
        y[k] = a1 * y[k - 1] + a2 * y[k - 2] + 2.0 * u[k - 1]
    series = Series("run.csv", "x", t, y + 0.1 * rng.normal(size=len(t)), {"f": u})
    mode = arx_correction([series])["dynamics"]["mode"]
    assert abs(mode["frequency_hz"] - f0) < 0.05 * f0
    assert abs(mode["damping"] - zeta) < 0.05


def test_the_leading_output_is_named() -> None:
    rng = np.random.default_rng(4)
    t = np.arange(300) * 0.1
    common = np.convolve(rng.normal(size=len(t) + 5), np.ones(5) / 5, mode="valid")[: len(t) + 1]
    first = Series("run.csv", "a", t, common[1:], {})
    later = Series("run.csv", "b", t, np.concatenate([np.zeros(3), common[1:-3]]), {})
    lead = arx_correction([first, later])["dynamics"]["leads"]
    assert lead["output"] == "a" and lead["other"] == "b"
    assert abs(lead["seconds"] - 0.3) < 1e-9
