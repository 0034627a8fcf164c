"""The basins that later right-valley checks of a branch start from, and re-fits that end in one."""

from types import SimpleNamespace

import numpy as np
from scipy.optimize import minimize_scalar

from fmuid.profiling.checks import (
    CheckOptions,
    basins,
    distinct_valleys,
    flip_starts,
    refit_from,
)
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


def _two_valleys(z: np.ndarray) -> np.ndarray:
    """Two minima along ``z1`` (near -1 and +1, the one near -1 lower), ``z0`` held fixed."""
    return np.array([3.0 * (z[1] ** 2 - 1.0), 0.2 * (z[1] + 0.3) + z[0]])


def test_a_check_refit_entering_a_known_basin_ends_there_and_others_run_to_their_minimum():
    """Against the minima of scipy's bounded scalar minimiser on each side of the ridge."""
    calls = []

    def residuals(z: np.ndarray) -> np.ndarray:
        calls.append(1)
        return _two_valleys(z)

    box = SimpleNamespace(
        residuals=residuals, z_lower=np.array([-1.0, -2.0]), z_upper=np.array([1.0, 2.0]), n_free=2
    )
    options = CheckOptions().refit

    def chi2_at(z1: float) -> float:
        r = _two_valleys(np.array([0.0, z1]))
        return float(r @ r)

    upper = minimize_scalar(chi2_at, bounds=(0.0, 2.0), method="bounded", options={"xatol": 1e-9})
    lower = minimize_scalar(chi2_at, bounds=(-2.0, 0.0), method="bounded", options={"xatol": 1e-9})
    site = WalkPoint(np.array([0.0, upper.x]), float(upper.fun))
    starts = [np.array([0.0, 1.6]), np.array([0.0, -1.7])]
    plain = refit_from(box, 0, 0.0, starts, options)
    n_plain = len(calls)
    calls.clear()
    stopped = refit_from(box, 0, 0.0, starts, options, [site], 1e-3)
    assert len(calls) < n_plain
    assert stopped[0] is site
    assert abs(plain[0].chi2 - upper.fun) < 1e-6
    for fit in (plain[1], stopped[1]):
        assert abs(fit.z[1] - lower.x) < 1e-4
        assert abs(fit.chi2 - lower.fun) < 1e-6


def test_flips_follow_the_valley_behind_the_bound():
    inner = np.array([0.5, 0.0, 1.0, 0.3])
    flips = [np.array([0.5, 1.0, 1.0, 0.3]), np.array([0.5, 0.0, -1.0, 0.3])]
    reached = WalkPoint(np.array([0.9, 0.97, 0.2, 0.1]), 7.0)
    kept = flip_starts(flips, inner, {(1, 1.0): reached})
    assert [key for key, _ in kept] == [(1, 1.0), (2, -1.0)]
    assert kept[0][1] is reached.z and kept[1][1] is flips[1]
    fresh = flip_starts(flips, inner, {})
    assert all(start is flip for (_, start), flip in zip(fresh, flips, strict=True))


def _close_valleys(z: np.ndarray) -> np.ndarray:
    """Two minima along ``z1`` near -0.01 and +0.01, a ridge at 0 (the one near -0.01 lower)."""
    u = z[1] / 0.01
    return np.array([3.0 * (u**2 - 1.0), 0.3 * (u + 0.3), z[0]])


def _close_minimum(lo: float, hi: float) -> WalkPoint:
    """One minimum of ``_close_valleys`` (``z0`` = 0) by scipy's bounded scalar minimiser."""
    found = minimize_scalar(
        lambda z1: float(np.sum(_close_valleys(np.array([0.0, z1])) ** 2)),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-12},
    )
    return WalkPoint(np.array([0.0, found.x]), float(found.fun))


def _counted_box() -> tuple[list[int], SimpleNamespace]:
    """A problem-shaped stand-in of ``_close_valleys`` and the list its runs are counted in."""
    calls: list[int] = []

    def residuals(z: np.ndarray) -> np.ndarray:
        calls.append(1)
        return _close_valleys(z)

    bounds = {"z_lower": np.array([-1.0, -2.0]), "z_upper": np.array([1.0, 2.0])}
    return calls, SimpleNamespace(residuals=residuals, n_free=2, **bounds)


def test_a_minimum_a_fit_left_short_of_in_its_own_valley_is_no_second_valley():
    """The chi2 halfway between two minima tells whether a ridge parts them."""
    calls, box = _counted_box()
    lower, upper = _close_minimum(-0.02, 0.0), _close_minimum(0.0, 0.02)
    assert lower.chi2 < upper.chi2
    z = lower.z + [0.0, 0.005]  # 0.00125 of z1's range off: beyond BASIN, in the same valley
    short = WalkPoint(z, float(np.sum(_close_valleys(z) ** 2)))
    kept = distinct_valleys([upper, short], box, lower, ceiling=1e3, tol=1e-3)
    assert len(kept) == 1 and kept[0] is upper.z
    assert len(calls) == 2  # one halfway run per pair that the basin test does not settle
    calls.clear()
    assert distinct_valleys([upper], box, lower, ceiling=0.5 * upper.chi2, tol=1e-3) == []
    assert not calls


def test_a_check_refit_near_a_known_minimum_ends_there_only_with_no_ridge_between():
    calls, box = _counted_box()
    lower, site = _close_minimum(-0.02, 0.0), _close_minimum(0.0, 0.02)
    options, near = CheckOptions().refit, CheckOptions().near
    [same] = refit_from(box, 0, 0.0, [np.array([0.0, 0.03])], options, [site], 1e-3, near)
    assert same is site
    assert len(calls) == 2  # the start, then the halfway run: no ridge
    [other] = refit_from(box, 0, 0.0, [np.array([0.0, -0.012])], options, [site], 1e-3, near)
    assert other is not site
    assert abs(other.z[1] - lower.z[1]) < 1e-6 and abs(other.chi2 - lower.chi2) < 1e-9
