"""Effects wrapped around the msd FMU against scipy solutions of the same augmented equations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.data import ParameterSpec, experiment_from_arrays
from fmuid.discrepancy import effects as fx
from fmuid.discrepancy.augment import AugmentedPredictor
from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.estimation.predictor import FmuPredictor

M, K, B = 1.1, 4.4, 1.6
TIME = np.linspace(0.0, 8.0, 161)
FORCE = 1.5 * np.sin(1.1 * TIME) + 0.8 * np.sin(2.9 * TIME)


def _p(name: str) -> tuple[AddedParameter, ...]:
    spec = ParameterSpec(start=0.0, lower=-100.0, upper=100.0, scale="lin")
    return (AddedParameter(name, "", "", spec, 0.0, "inside"),)


def _msd(force: object, extra_state: bool = False, tau: float = 1.0) -> np.ndarray:
    """x of m x'' + b x' + k x = force(t, x, v), with a first-order lag state of x if asked."""

    def rhs(t: float, s: np.ndarray) -> list[float]:
        x, v = s[0], s[1]
        out = [v, (force(t, x, v) - B * v - K * x) / M]  # type: ignore[operator]
        return out + ([(x - s[2]) / tau] if extra_state else [])

    y0 = [0.0, 0.0, 0.0] if extra_state else [0.0, 0.0]
    sol = solve_ivp(rhs, (0.0, TIME[-1]), y0, t_eval=TIME, rtol=1e-10, atol=1e-12, max_step=0.01)
    return sol.y[2] if extra_state else sol.y[0]


def _predict(msd_fmu: Path, effects: tuple[fx.Effect, ...], values: dict[str, float]) -> np.ndarray:
    exp = experiment_from_arrays("e.csv", TIME, {"f": FORCE, "x": np.zeros(TIME.size)})
    predictor = AugmentedPredictor(FmuPredictor(msd_fmu, {"m": M, "k": K, "b": B}, ["f"]), effects)
    return predictor.predict(values, exp, ["x"])[:, 0]


def u(t: float) -> float:
    return float(np.interp(t, TIME, FORCE))


@pytest.mark.parametrize(
    ("effects", "values", "force"),
    [
        (
            (fx.InputOffset("f", _p("o")), fx.InputGain("f", _p("g"))),
            {"o": 0.3, "g": 1.2},
            lambda t, x, v: 1.2 * (u(t) + 0.3),
        ),
        (
            (fx.InputSaturation("f", _p("s")),),
            {"s": 1.0},
            lambda t, x, v: float(np.clip(u(t), -1.0, 1.0)),
        ),
        (
            (fx.InputDeadZone("f", _p("d")),),
            {"d": 0.5},
            lambda t, x, v: u(t) - float(np.clip(u(t), -0.5, 0.5)),
        ),
        (
            (fx.FeedbackPolynomial("f", _p("c"), source="x", power=3),),
            {"c": -6.0},
            lambda t, x, v: u(t) - 6.0 * x**3,
        ),
        (
            (fx.FeedbackFriction("f", _p("c"), source="v", width=0.05),),
            {"c": 0.4},
            lambda t, x, v: u(t) - 0.4 * np.tanh(v / 0.05),
        ),
    ],
)
def test_input_and_feedback_effects_match_the_augmented_ode(
    msd_fmu: Path, effects: tuple[fx.Effect, ...], values: dict[str, float], force: object
) -> None:
    expected = _msd(force)
    got = _predict(msd_fmu, effects, values)
    # clipping acts at the fine grid's points (a quarter of the data interval): first order there
    assert np.max(np.abs(got - expected)) < 2e-3 * np.max(np.abs(expected))


def test_output_lag_bias_gain_and_saturation_act_on_the_recording(msd_fmu: Path) -> None:
    lagged = _msd(lambda t, x, v: u(t), extra_state=True, tau=0.3)
    effects = (
        fx.OutputLag("", _p("tau")),
        fx.OutputGain("x", _p("g")),
        fx.OutputBias("x", _p("b")),
        fx.OutputSaturation("x", _p("top"), upper=True),
    )
    got = _predict(msd_fmu, effects, {"tau": 0.3, "g": 0.9, "b": 0.01, "top": 0.2})
    expected = np.minimum(0.9 * lagged + 0.01, 0.2)
    assert np.max(np.abs(got - expected)) < 1e-4 * np.max(np.abs(expected))
    assert np.any(expected == 0.2)


def test_an_offset_and_a_gain_change_the_input_samples_alone(msd_fmu: Path) -> None:
    """No fine grid: the FMU runs as on a record of the changed samples, to the last bit."""
    effects = (fx.InputOffset("f", _p("o")), fx.InputGain("f", _p("g")))
    got = _predict(msd_fmu, effects, {"o": 0.3, "g": 1.2})
    changed = experiment_from_arrays(
        "e.csv", TIME, {"f": (FORCE + 0.3) * 1.2, "x": np.zeros(TIME.size)}
    )
    plain = FmuPredictor(msd_fmu, {"m": M, "k": K, "b": B}, ["f"]).predict({}, changed, ["x"])
    np.testing.assert_array_equal(got, plain[:, 0])


def test_changed_inputs_are_kept_by_the_effects_values(msd_fmu: Path) -> None:
    """The same values give the same arrays (the run plan is reused); each result as uncached."""
    exp = experiment_from_arrays("e.csv", TIME, {"f": FORCE, "x": np.zeros(TIME.size)})
    effects = (fx.InputOffset("f", _p("o")), fx.InputLag("f", _p("tau")))

    def predictor() -> AugmentedPredictor:
        return AugmentedPredictor(FmuPredictor(msd_fmu, {"m": M, "k": K, "b": B}, ["f"]), effects)

    kept = predictor()
    first = kept._inputs({"o": 0.3, "tau": 0.2}, exp)
    assert kept._inputs({"o": 0.3, "tau": 0.2}, exp)[1]["f"] is first[1]["f"]
    assert kept._inputs({"o": 0.3, "tau": 0.5}, exp)[1]["f"] is not first[1]["f"]
    for values in ({"o": 0.3, "tau": 0.2}, {"o": -0.1, "tau": 0.2}, {"o": 0.3, "tau": 0.2}):
        np.testing.assert_array_equal(
            kept.predict(values, exp, ["x"]), predictor().predict(values, exp, ["x"])
        )
