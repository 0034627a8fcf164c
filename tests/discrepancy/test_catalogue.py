"""The generic candidates reproduce the independent field truth's effects (scipy model)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import fieldtruth as ft
from fmuid.data import ParameterSpec
from fmuid.discrepancy import effects as fx
from fmuid.discrepancy.augment import AugmentedPredictor
from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.estimation.predictor import FmuPredictor


def _added(name: str) -> tuple[AddedParameter, ...]:
    spec = ParameterSpec(start=0.1, lower=-1.0, upper=1.0, scale="lin")
    return (AddedParameter(name, "", "", spec, 0.0, "inside"),)


WRAPPERS = {
    "output_lag": ("tau_outputs", fx.OutputLag("", _added("tau_outputs"))),
    "input_lag": ("tau_delta", fx.InputLag("delta", _added("tau_delta"))),
    "input_delay": ("delay_delta", fx.InputDelay("delta", _added("delay_delta"))),
    "input_offset": ("offset_delta", fx.InputOffset("delta", _added("offset_delta"))),
}


@pytest.mark.parametrize("effect", list(WRAPPERS))
def test_wrapper_matches_field_truth(tractor_fmu: Path, effect: str) -> None:
    magnitude = ft.MAGNITUDES[effect][1]
    case = ft.make_case(effect, magnitude, seed=3, rate=10.0, snr=50.0)
    exp = case.experiments[1]
    t_in, u_in = exp.input_samples("delta")
    truth = ft.simulate_truth(case.truth, t_in, u_in, exp.time, effect, magnitude)
    name, wrapper = WRAPPERS[effect]
    predictor = AugmentedPredictor(FmuPredictor(tractor_fmu, {}, ["delta"]), (wrapper,))
    tires = {k: case.truth[k] for k in ft.BOUNDS}
    y = predictor.predict({**tires, name: magnitude}, exp, ["gam_t", "gam_i"])
    sigma = float(np.nanmax(exp.columns["sigma_gam_t"]))
    assert np.max(np.abs(y[:, 0] - truth["gam_t"])) < 0.05 * sigma
    assert np.max(np.abs(y[:, 1] - truth["gam_i"])) < 0.05 * sigma


@pytest.mark.parametrize("effect", ["output_lag", "input_lag"])
def test_rows_a_rounding_error_apart_neither_blow_up_the_grid_nor_move_the_lag(
    tractor_fmu: Path, effect: str
) -> None:
    from fmuid.data import experiment_from_arrays

    time = np.arange(0.0, 6.0001, 0.1)
    steer = 0.05 * np.sin(time)
    near = np.insert(time, 11, time[10] + 2e-15)
    columns = {"delta": np.interp(near, time, steer), "gam_t": np.zeros(len(near))}
    twin = experiment_from_arrays("near.csv", near, columns)
    plain = experiment_from_arrays("plain.csv", time, {"delta": steer, "gam_t": np.zeros(61)})
    name, wrapper = WRAPPERS[effect]
    predictor = AugmentedPredictor(FmuPredictor(tractor_fmu, {}, ["delta"]), (wrapper,))
    values = {**ft.NOMINAL, name: 0.2}
    y_near = predictor.predict(values, twin, ["gam_t"])[:, 0]
    y_plain = predictor.predict(values, plain, ["gam_t"])[:, 0]
    # the same lag within the grids' discretisation error (the near row makes its grid finer)
    scale = float(np.max(np.abs(y_plain)))
    assert np.max(np.abs(np.delete(y_near, 11) - y_plain)) < 1e-4 * scale
