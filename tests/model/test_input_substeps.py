"""Inputs of co-simulation FMUs without input derivatives: midpoint sub-steps, against scipy."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.model.simulator import Simulator

M, K, B = 1.1, 4.4, 1.6
RAMP_T = np.concatenate(([0.0], np.arange(0.5, 2.5 + 1e-9, 0.25), [6.0]))
"""The ramp sampled every 0.25 s, so that its sub-steps (at most 8 per sample interval) are
``input_step``'s."""
RAMP_F = np.interp(RAMP_T, [0.0, 0.5, 2.5, 6.0], [0.0, 0.0, 40.0, 40.0])
T_OUT = np.round(np.arange(0.0, 6.0 + 1e-9, 0.25), 10)


@pytest.fixture(scope="module")
def held_msd(msd_fmu: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The built-in msd with ``canInterpolateInputs="false"`` (fmuid must sub-step its input)."""
    target = tmp_path_factory.mktemp("held") / "msd.fmu"
    with zipfile.ZipFile(msd_fmu) as src, zipfile.ZipFile(target, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = data.replace(b'canInterpolateInputs="true"', b'canInterpolateInputs="false"')
            dst.writestr(item, data)
    return target


def _reference() -> np.ndarray:
    """m x'' + b x' + k x = f with the exact ramp, solved by scipy piecewise between corners."""
    x, out = np.zeros(2), []
    for t0, t1, f0, f1 in zip(RAMP_T[:-1], RAMP_T[1:], RAMP_F[:-1], RAMP_F[1:], strict=True):
        rate = (f1 - f0) / (t1 - t0)
        inside = T_OUT[(T_OUT >= t0) & (T_OUT < t1)]
        sol = solve_ivp(
            lambda t, s, t0=t0, f0=f0, rate=rate: [
                s[1],
                (f0 + rate * (t - t0) - B * s[1] - K * s[0]) / M,
            ],
            (t0, t1),
            x,
            t_eval=np.append(inside, t1),
            rtol=1e-12,
            atol=1e-12,
            method="DOP853",
        )
        out.extend(sol.y[0][:-1])
        x = sol.y[:, -1]
    return np.append(out, x[0])


def test_midpoint_sub_steps_are_second_order(held_msd: Path) -> None:
    reference = _reference()
    errors = []
    for input_step in (0.125, 0.0625):
        sim = Simulator(held_msd, input_step=input_step)
        assert "midpoint" in sim.input_handling
        y = sim.simulate({}, RAMP_T, {"f": RAMP_F}, T_OUT, ["x"])[:, 0]
        sim.close()
        errors.append(float(np.max(np.abs(y - reference))))
    assert errors[1] < 3e-4 * np.max(np.abs(reference))  # held at the start value: 1.8e-2
    assert 3.5 < errors[0] / errors[1] < 4.5  # halving the sub-step: 4x (first order: 2x)
