"""The native co-simulation master loop against the Python loop it replaces (to 1e-12)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from fmuid.errors import FmuError
from fmuid.model.native import native_library
from fmuid.model.simulator import Simulator

from .foreign import reference_fmu

T = np.linspace(0.0, 4.0, 1601)
U = np.sin(1.3 * T) + 0.5 * np.sin(3.1 * T)
RAMP_T = np.array([0.0, 1.0, 1.5, 4.0])
RAMP = np.array([0.0, 0.0, 1.0, 1.0])
FEEDTHROUGH = ("Float64_continuous_input", "Float64_continuous_output")


def _both(sim: Simulator, run: Callable[[], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Run with the native loop, then with the Python loop."""
    assert native_library() is not None, "gcc could not compile the native loop"
    sim.native = True
    native = run()
    sim.native = False
    python = run()
    sim.close()
    return native, python


def _case(request: pytest.FixtureRequest, name: str) -> tuple[Path, dict, list[str], np.ndarray]:
    if name == "msd":
        return request.getfixturevalue("msd_fmu"), {"f": 40 * U}, ["x", "v"], T
    if name == "tractor":
        return request.getfixturevalue("tractor_fmu"), {"delta": 0.1 * U}, ["gam_t", "psi_i"], T
    version = name.split("/")[0]
    inputs = {FEEDTHROUGH[0]: np.interp(T, RAMP_T, RAMP)} if "Feedthrough" in name else {}
    outputs = [FEEDTHROUGH[1]] if "Feedthrough" in name else ["x0", "x1"]
    return reference_fmu(version, name.split("/")[1]), inputs, outputs, T


@pytest.mark.parametrize(
    "name", ["msd", "tractor", "fmi2/Feedthrough", "fmi3/Feedthrough", "fmi3/VanDerPol"]
)
def test_native_loop_equals_the_python_loop(request: pytest.FixtureRequest, name: str) -> None:
    path, inputs, outputs, t = _case(request, name)
    sim = Simulator(path)
    t_in = t if inputs else t[:1]
    t_out = t[::8]
    native, python = _both(sim, lambda: sim.simulate({}, t_in, inputs, t_out, outputs))
    assert np.all(np.isfinite(native))
    np.testing.assert_allclose(native, python, rtol=0, atol=1e-12)


def test_native_loop_raises_the_python_loops_errors(msd_fmu: Path) -> None:
    step_t = np.array([0.0, 1.0, 1.0, 4.0])
    cases = {
        np.inf: r"fmi2SetReal returned fmi2Error for the inputs at t = 1\.0 s",
        1e308: r"fmi2DoStep returned fmi2Error in the step from t = 1\.0 s",
    }
    for bad, where in cases.items():
        sim = Simulator(msd_fmu)
        messages: list[str] = []

        def run(
            sim: Simulator = sim, bad: float = bad, where: str = where, messages: list = messages
        ) -> np.ndarray:
            with pytest.raises(FmuError, match=where) as caught, np.errstate(invalid="ignore"):
                sim.simulate({}, step_t, {"f": np.array([0.0, 0.0, bad, bad])}, T, ["x"])
            messages.append(str(caught.value))
            return np.zeros(1)

        _both(sim, run)
        assert messages[0] == messages[1]


def test_native_loop_stops_where_the_fmu_asks() -> None:
    sim = Simulator(reference_fmu("fmi3", "Stair"))
    t = np.arange(0.0, 9.01, 0.5)
    native, python = _both(sim, lambda: sim.simulate({}, t[:1], {}, t, []))
    assert native.shape == python.shape == (t.size, 0)
    sim = Simulator(reference_fmu("fmi2", "Stair"))
    with pytest.raises(FmuError, match=r"stopped the simulation at t = 9\.0 s"):
        sim.simulate({}, t[:1], {}, np.append(t, 10.0), [])
    sim.close()
