"""The basins that later right-valley checks of a branch start from."""

from types import SimpleNamespace

import numpy as np

from fmuid.profiling.checks import basins
from fmuid.profiling.points import WalkPoint

BOX = SimpleNamespace(z_lower=np.array([0.0, -1.0]), z_upper=np.array([1.0, 1.0]))


def test_basins_drop_the_walks_own_and_repeats_and_keep_the_lowest():
    walk = WalkPoint(np.array([0.5, 0.0]), 10.0)
    found = [
        WalkPoint(np.array([0.5, 0.0005]), 9.99),  # the walk's basin (within 1e-3 of the range)
        WalkPoint(np.array([0.5, 0.6]), 12.0),
        WalkPoint(np.array([0.5, 0.6015]), 12.5),  # same basin as the one at 0.6 (1e-3 of 2)
        WalkPoint(np.array([0.5, -0.7]), 11.0),
        WalkPoint(np.array([0.5, 0.9]), 15.0),
    ]
    kept = basins(BOX, found, [walk], keep=3)
    assert [p.chi2 for p in kept] == [11.0, 12.0, 15.0]
    assert [p.chi2 for p in basins(BOX, found, [walk], keep=2)] == [11.0, 12.0]
    assert basins(BOX, found[:1], [walk], keep=3) == []
