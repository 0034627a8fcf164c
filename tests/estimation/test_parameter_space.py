"""The parameter space against closed forms: log10 / linear coordinates, bounds, at-bound."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fmuid.data import ParameterSpec
from fmuid.estimation.space import (
    BOUND_TOLERANCE,
    ParameterSpace,
    value_step,
    value_to_z,
    z_to_value,
)

SPACE = ParameterSpace(("k", "c"), ("log", "lin"), (1e-2, -5.0), (1e3, 5.0))


def test_coordinates_are_log10_and_identity():
    z = SPACE.to_z({"k": 100.0, "c": -2.5})
    assert z == pytest.approx([2.0, -2.5], abs=1e-15)
    assert SPACE.to_z([0.1, 3.0]) == pytest.approx([-1.0, 3.0], abs=1e-15)
    assert SPACE.from_z(np.array([-1.5, 0.25])) == pytest.approx(
        {"k": 10**-1.5, "c": 0.25}, rel=1e-15
    )
    assert SPACE.z_lower == pytest.approx([-2.0, -5.0], abs=1e-15)
    assert SPACE.z_upper == pytest.approx([3.0, 5.0], abs=1e-15)
    assert list(SPACE.lower) == [1e-2, -5.0]
    assert list(SPACE.upper) == [1e3, 5.0]


def test_value_step_is_the_derivative_of_the_inverse():
    # d(10**z)/dz = ln(10) * 10**z; a linear parameter moves one for one
    assert value_step(0.5, 200.0, "log") == pytest.approx(0.5 * math.log(10) * 200.0, rel=1e-15)
    assert value_step(0.5, 200.0, "lin") == 0.5


@given(
    st.floats(min_value=1e-2, max_value=1e3),
    st.floats(min_value=-5.0, max_value=5.0),
)
def test_round_trip(k, c):
    back = SPACE.from_z(SPACE.to_z({"k": k, "c": c}))
    assert back["k"] == pytest.approx(k, rel=1e-13)
    assert back["c"] == c
    assert z_to_value(value_to_z(k, "log"), "log") == pytest.approx(k, rel=1e-13)


def test_at_bound_is_a_fraction_of_the_span_in_z():
    span = np.array([5.0, 10.0])  # decades of k, units of c
    inside = np.array([0.0, 0.0])
    assert SPACE.at_bound(inside) == ()
    near_lower = SPACE.z_lower + 0.5 * BOUND_TOLERANCE * span
    assert SPACE.at_bound(near_lower) == ("k", "c")
    assert SPACE.at_bound(near_lower, skip=0) == ("c",)
    off_upper = SPACE.z_upper - 2.0 * BOUND_TOLERANCE * span
    assert SPACE.at_bound(off_upper) == ()
    assert SPACE.at_bound(SPACE.z_upper) == ("k", "c")


def test_from_specs_resolves_the_default_scale():
    space = ParameterSpace.from_specs(
        {
            "k": ParameterSpec(start=1.0, lower=0.1, upper=10.0),
            "x": ParameterSpec(start=0.0, lower=-1.0, upper=1.0),
        }
    )
    assert space.scales == ("log", "lin")
    assert space.z_lower == pytest.approx([-1.0, -1.0])


@pytest.mark.parametrize(
    ("scales", "lower", "upper", "words"),
    [
        (("log", "cubic"), (1.0, 0.0), (2.0, 1.0), "scale 'cubic'"),
        (("log", "lin"), (1.0, 2.0), (2.0, 1.0), "'c': lower bound 2.0 is above"),
        (("log", "lin"), (0.0, 0.0), (2.0, 1.0), "'k': log scale needs a positive"),
        (("log",), (1.0,), (2.0,), "2 names"),
    ],
)
def test_bad_space_names_what_is_wrong(scales, lower, upper, words):
    with pytest.raises(ValueError, match=words):
        ParameterSpace(("k", "c"), scales, lower, upper)


def test_wrong_number_of_values_is_named():
    with pytest.raises(ValueError, match="2 values needed"):
        SPACE.to_z([1.0, 2.0, 3.0])
