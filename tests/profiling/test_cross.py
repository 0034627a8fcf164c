"""A valley one parameter's walk misses and another's walks through: the branches checked against
each other (profiling/cross.py), against a grid of re-fits of the closed-form objective."""

from types import SimpleNamespace

import numpy as np

from fmuid.profiling.branch import settle_branch
from fmuid.profiling.cross import CrossRecord, beyond_end, cross_check
from fmuid.profiling.engine import thresholds
from fmuid.profiling.walk import WalkOptions


def _bump(z1: float) -> float:
    """Valley B's weight: 1 at ``z1 = 0.7``, nothing at the optimum's ``z1 = 0.2``."""
    return float(np.exp(-(((z1 - 0.7) / 0.05) ** 2)))


def _residuals(z: np.ndarray) -> np.ndarray:
    """Valley A (weight ``1 - b``): ``3 z0``; valley B: ``1.5 + 0.1 z0``; ``z1`` pulled to 0.2.

    For ``z0 < 0`` a ``z1`` between 0.62 and 0.7 mixes the valleys to a zero first residual, so
    the profile of ``z0`` flattens at about 0.05 beyond ``z0 = -0.08``; the walk of ``z0``
    re-fits ``z1`` from 0.2, where the bump's slope is nil, and follows ``9 z0^2``.
    """
    b = _bump(float(z[1]))
    return np.array([(1.0 - b) * 3.0 * z[0] + b * (1.5 + 0.1 * z[0]), 0.5 * (z[1] - 0.2)])


PROBLEM = SimpleNamespace(
    residuals=_residuals,
    z_lower=np.array([-5.0, 0.0]),
    z_upper=np.array([5.0, 1.0]),
    n_free=2,
    n_data=2,
)
Z_HAT = np.array([0.0, 0.2])
THR = thresholds(0.68, 2)
SD = (1.0 / 3.0, 2.0)
JACOBIAN = -np.diag([3.0, 0.5])


def _settle(index: int, direction: int, valleys: tuple = ()):  # noqa: ANN202 - a BranchResult
    return settle_branch(
        PROBLEM,  # type: ignore[arg-type]
        Z_HAT,
        0.0,
        index,
        direction,
        THR,
        SD[index],
        WalkOptions(),
        valleys=valleys,
        jacobian=JACOBIAN,
    )


def _profile_on_grid(z0: float) -> float:
    """The profile of ``z0``: the lowest chi2 over a fine grid of ``z1`` (independent of fmuid)."""
    grid = np.linspace(0.0, 1.0, 20001)
    return min(float(np.sum(_residuals(np.array([z0, z1])) ** 2)) for z1 in grid)


def test_a_point_of_another_branch_beyond_an_end_settles_that_branch_again():
    lower = _settle(0, -1)
    assert abs(lower.ends["pointwise"].z - -np.sqrt(THR["pointwise"]) / 3.0) < 1e-3
    assert abs(lower.ends["simultaneous"].z - -np.sqrt(THR["simultaneous"]) / 3.0) < 1e-3
    branches = [lower, _settle(0, 1), _settle(1, -1), _settle(1, 1)]
    beyond = beyond_end(branches, lower, "simultaneous", 0.0, THR["simultaneous"], 1e-3)
    assert beyond and all(p.z[0] < lower.ends["simultaneous"].z for p in beyond)
    assert all(p.chi2 < THR["simultaneous"] for p in beyond)
    calls = []

    def settle(again):  # noqa: ANN001, ANN202
        calls.append(sorted(again))
        return [_settle(i, d, (point,)) for (i, d), point in again.items()]

    record = CrossRecord()
    checked = cross_check(PROBLEM, branches, 0.0, THR, WalkOptions(), settle, record)  # type: ignore[arg-type]
    assert calls == [[(0, -1)]]
    assert record.ends >= 1 and record.probes >= 1 and record.resettled == 1
    assert checked[1:] == branches[1:]
    again = checked[0]
    assert again.ends["pointwise"].z is None and again.ends["simultaneous"].z is None
    for z0 in (-0.5, -2.0, -5.0):
        assert _profile_on_grid(z0) < THR["pointwise"]


def test_no_point_beyond_an_end_costs_no_simulation():
    branches = [_settle(0, 1), _settle(1, 1)]
    record = CrossRecord()

    def settle(again):  # noqa: ANN001, ANN202
        raise AssertionError("nothing to settle again")

    assert cross_check(PROBLEM, branches, 0.0, THR, WalkOptions(), settle, record) == branches  # type: ignore[arg-type]
    assert record.to_dict() == {"ends": 0, "probes": 0, "resettled": 0, "simulations": 0}
