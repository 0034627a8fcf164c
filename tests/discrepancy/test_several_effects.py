"""Two effects at once on the msd FMU (an input offset and a hardening spring), named in turn.

The data come from scipy's solution of m x'' + b x' + k x + 8 x^3 = f + 0.05 (not from the FMU);
a second record is held out. The diagnosis must add both, give intervals containing the truth,
and lower the held-out error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.discrepancy import diagnose

M, K, B, CUBIC, OFFSET, SIGMA = 1.1, 4.4, 1.6, -8.0, 0.05, 0.005


def _record(name: str, seed: int):  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 30.0, 0.05)
    freqs, phases = rng.uniform(0.1, 1.5, 8), rng.uniform(0.0, 2 * np.pi, 8)
    u = 0.6 * sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, phases))

    def rhs(tt: float, s: np.ndarray) -> list[float]:
        x, v = s
        return [v, (np.interp(tt, t, u) + OFFSET + CUBIC * x**3 - B * v - K * x) / M]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.01)
    x = sol.y[0] + rng.normal(0.0, SIGMA, t.size)
    return experiment_from_arrays(name, t, {"f": u, "x": x})


@pytest.mark.slow
def test_an_offset_and_a_hardening_spring_are_both_named(msd_fmu: Path) -> None:
    spec = spec_from_json(
        '{"parameters": {"m": {"start": 1, "lower": 0.1, "upper": 10},'
        ' "k": {"start": 4, "lower": 0.1, "upper": 20}, "b": {"start": 1, "lower": 0.1,'
        ' "upper": 10}}, "inputs": ["f"], "outputs": {"x": {"sigma": 0.005}}, "seed": 0,'
        ' "global_search": false}'
    )
    result = diagnose(
        msd_fmu, [_record("train.csv", 1)], spec, test_data=[_record("test.csv", 2)]
    ).to_dict()
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
