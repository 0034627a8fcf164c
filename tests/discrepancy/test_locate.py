"""Where a named effect acts: the chi2 it removes by output, experiment, time and band."""

from __future__ import annotations

import numpy as np

from fmuid.discrepancy.locate import effect_location
from fmuid.discrepancy.residual_tests import Series


def test_the_effect_is_located_where_and_at_the_frequency_it_acts() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 30.0, 0.1)
    burst = np.where((t > 10.0) & (t < 12.0), 2.0 * np.sin(2 * np.pi * 1.5 * t), 0.0)
    noise = [rng.normal(size=len(t)) for _ in range(2)]
    before = [Series("a.csv", "y1", t, noise[0] + burst), Series("a.csv", "y2", t, noise[1])]
    after = [Series("a.csv", "y1", t, noise[0]), Series("a.csv", "y2", t, noise[1])]
    where = effect_location(before, after)
    assert where["outputs"] == ["y1"] and where["experiments"] == ["a.csv"]
    assert any(start <= 11.0 <= end for start, end in where["time_windows"])
    lo, hi = where["frequency_hz"]
    assert lo <= 1.5 <= hi and hi - lo < 1.5
    assert where["chi2_gain"]["a.csv/y2"] == 0.0
