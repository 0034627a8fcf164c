"""A lower valley behind another parameter's other bound, found at the CI end by a re-fit from
that bound (not by the diverse starts), against scipy multi-start re-fits."""

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from fmuid.profiling.branch import settle_branch
from fmuid.profiling.checks import bound_flips
from fmuid.profiling.points import WalkPoint
from fmuid.profiling.walk import WalkOptions

sys.path.insert(0, str(Path(__file__).parent))
from reference import ReferenceProfile  # noqa: E402

#: Where the ridge between the valleys lies along ``z1`` (in [0, 1]): valley B's basin is the
#: last 2 % of the range, which seeded diverse starts rarely reach.
RIDGE = 0.98


def _residuals(z: np.ndarray) -> np.ndarray:
    """Valley A with ``z1`` on its lower bound 0 (chi2 ``4 + 9 z0^2``, the estimate's) and
    valley B with ``z1`` on its upper bound 1 (chi2 ``4 + (2 + 0.1 z0)^2``: lower than A
    beyond ``z0 = 0.69``); each valley's own minimum lies beyond its bound."""
    w = (z[1] - RIDGE) / (RIDGE if z[1] < RIDGE else 1.0 - RIDGE)
    mix = (1.0 - w) / 2.0
    return np.array([10.0 * (w * w - 1.2), mix * 3.0 * z[0] + (1.0 - mix) * (2.0 + 0.1 * z[0])])


def test_bound_flips_move_each_bound_parameter_but_the_profiled_one():
    problem = SimpleNamespace(z_lower=np.zeros(3), z_upper=np.array([1.0, 2.0, 4.0]), n_free=3)
    flips = bound_flips(problem, np.array([0.0, 2.0, 1.0]), 0)
    assert [list(f) for f in flips] == [[0.0, 0.0, 1.0]]
    assert bound_flips(problem, np.array([0.0, 1.0, 1.0]), 0) == []


def test_a_parameter_the_walk_held_on_a_bound_is_flipped_at_an_end_just_beside_it():
    """Whether a re-fit lands on a bound or a hair inside it is the optimiser's tolerance: a
    parameter on its upper bound at a walk point and 1e-4 of its span inside it at the end is
    moved to its lower bound; one never on a bound is left alone."""
    problem = SimpleNamespace(z_lower=np.zeros(3), z_upper=np.array([1.0, 2.0, 4.0]), n_free=3)
    end = np.array([0.5, 2.0 - 2e-4, 1.0])
    path = [np.array([0.1, 1.5, 1.0]), np.array([0.3, 2.0, 1.2])]
    assert bound_flips(problem, end, 0) == []
    flips = bound_flips(problem, end, 0, path)
    assert [list(f) for f in flips] == [[0.5, 0.0, 1.0]]
    assert bound_flips(problem, end, 0, [np.array([0.1, 1.5, 1.0])]) == []


def test_an_end_in_a_valley_behind_the_other_bound_is_the_exact_crossing():
    """The walk follows valley A (``z1`` on its lower bound) and crosses the threshold 5 at
    ``z0 = 0.745``; the profile (lower envelope) crosses in valley B at ``z0 = 2.36`` (closed
    form, and the lowest of scipy re-fits from 50 Latin-hypercube starts there)."""
    problem = SimpleNamespace(
        residuals=_residuals,
        z_lower=np.array([-5.0, 0.0]),
        z_upper=np.array([5.0, 1.0]),
        n_free=2,
        n_data=2,
    )
    estimate = WalkPoint(np.array([0.0, 0.0]), 4.0)
    result = settle_branch(
        problem, estimate.z, 4.0, 0, 1, {"simultaneous": 5.0}, 1.0 / 3.0, WalkOptions()
    )
    exact = (np.sqrt(5.0) - 2.0) / 0.1
    ref = ReferenceProfile(problem, 0, estimate.z, starts=50)
    assert abs(ref.chi2(exact) - 9.0) < 1e-6
    assert ref.chi2(np.sqrt(5.0) / 3.0) < 9.0 - 0.5
    end = result.ends["simultaneous"]
    assert abs(end.z - exact) < 0.01 * exact
    assert result.quality.lower_valleys >= 1


def test_a_flip_that_comes_back_spends_no_diverse_starts_and_the_end_is_exact():
    """One valley with ``z1`` pinned on its lower bound (its minimum lies below it): the flip
    to the upper bound re-fits back onto the lower one, a bound with no valley behind it, so
    the end is checked by that one re-fit; the end is the closed-form ``sqrt(5) / 3``."""
    problem = SimpleNamespace(
        residuals=lambda z: np.array([3.0 * z[0], 2.0 + 10.0 * (z[1] + 0.5)]),
        z_lower=np.array([-5.0, 0.0]),
        z_upper=np.array([5.0, 1.0]),
        n_free=2,
        n_data=2,
    )
    z_hat = np.array([0.0, 0.0])
    chi2_hat = float(np.sum(problem.residuals(z_hat) ** 2))
    result = settle_branch(
        problem, z_hat, chi2_hat, 0, 1, {"simultaneous": 5.0}, 1.0 / 3.0, WalkOptions()
    )
    assert abs(result.ends["simultaneous"].z - np.sqrt(5.0) / 3.0) < 1e-3 * np.sqrt(5.0) / 3.0
    assert result.quality.checks == 1
    assert result.quality.starts == 1
    assert result.quality.lower_valleys == 0
