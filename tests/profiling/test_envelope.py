"""The lower envelope of a re-walk and the walk before it (closed-form points)."""

import numpy as np

from fmuid.profiling.points import WalkPoint, lower_envelope


def _p(z: float, chi2: float) -> WalkPoint:
    return WalkPoint(np.array([z, 0.0]), chi2)


def test_an_old_walk_lower_further_out_stays_and_the_new_points_above_it_go():
    """The re-walk found a lower valley near the estimate and then rose over the threshold at
    ``z = 3``, where the walk before it stayed low up to the bound: the envelope keeps the new
    points inside, the old ones outside, and drops the new point above the old line."""
    old = [_p(1.0, 1.5), _p(2.0, 3.0), _p(3.0, 4.0), _p(4.0, 4.5)]
    new = [_p(1.0, 1.2), _p(2.5, 4.6), _p(4.0, 8.7)]
    kept = lower_envelope(new, old, 0, 0.0, 0.01)
    assert [(float(p.z[0]), p.chi2) for p in kept] == [
        (1.0, 1.2),
        (2.0, 3.0),
        (3.0, 4.0),
        (4.0, 4.5),
    ]


def test_points_beyond_the_other_walk_stay_and_points_above_its_line_go():
    """Walking down (``z < 0``): the new walk rose over the threshold at ``z = -2``, above the
    old walk's line to its point at ``z = -3`` (which lies beyond the new walk and stays):
    the new point goes. When the old walk's line there is higher, the new point stays."""
    old = [_p(-1.0, 1.0), _p(-3.0, 2.0)]
    new = [_p(-1.0, 0.8), _p(-2.0, 6.0)]
    assert [p.chi2 for p in lower_envelope(new, old, 0, 0.0, 0.01)] == [0.8, 2.0]
    higher = [_p(-1.0, 1.0), _p(-3.0, 12.0)]
    assert [p.chi2 for p in lower_envelope(new, higher, 0, 0.0, 0.01)] == [0.8, 6.0, 12.0]


def test_the_outermost_crossing_survives_when_the_old_walk_went_further():
    """The re-walk's last point lies above the old line but the old walk's points beyond it
    (over the threshold too) stay, so the envelope still crosses where the old walk did."""
    shared = _p(-1.0, 2.2)
    old = [shared, _p(-1.7, 6.6), _p(-2.3, 11.8)]
    new = [shared, _p(-2.0, 9.8)]
    kept = lower_envelope(new, old, 0, 0.0, 0.01)
    assert [(float(p.z[0]), p.chi2) for p in kept] == [(-1.0, 2.2), (-1.7, 6.6), (-2.3, 11.8)]


def test_a_re_walk_below_the_old_walk_everywhere_replaces_it_and_keeps_its_failures():
    old = [_p(1.0, 2.0), _p(2.0, 5.0)]
    failed = WalkPoint(np.array([3.0, 0.0]), float("nan"), "the simulation failed")
    new = [_p(1.0, 1.0), _p(2.0, 4.0), failed]
    kept = lower_envelope(new, old, 0, 0.0, 0.01)
    assert kept[:2] == new[:2] and kept[2] is failed
