"""The native co-simulation master loop against the Python loop it replaces (to 1e-12)."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from fmuid.errors import FmuError
from fmuid.model.feedback import Feedback, FeedbackTerm
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
    """An input the FMU refuses, and a step whose state overflows (a light undamped mass)."""
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
                f = np.array([0.0, 0.0, bad, bad])
                sim.simulate({"m": 1e-3, "b": 0.0}, step_t, {"f": f}, T, ["x"])
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


def _terms(source: str, target: str, rate: str | None, scale: float) -> tuple[FeedbackTerm, ...]:
    terms = (
        FeedbackTerm(target, source, False, "power", -3.0 * scale, 3),
        FeedbackTerm(target, rate or source, False, "tanh", -0.3 * scale, 0.05),
        FeedbackTerm(target, source, False, "dead", -2.0 * scale, 0.1),
    )
    return (*terms, FeedbackTerm(target, source, True, "tanh", -0.2, 0.1)) if rate else terms


@pytest.mark.parametrize("name", ["msd", "fmi2/Feedthrough", "fmi3/Feedthrough"])
def test_native_feedback_equals_the_python_loop(request: pytest.FixtureRequest, name: str) -> None:
    path, inputs, outputs, t = _case(request, name)
    (target, u), source = next(iter(inputs.items())), outputs[0]
    # a feedthrough's loop is a map u_k = r_k + g(u_(k-1)): small gains keep it contracting
    u, rate, scale = (U, "v", 1.0) if name == "msd" else (u, None, 0.03)
    feedback = Feedback(_terms(source, target, rate, scale), 0.002)
    sim = Simulator(path)
    t_io = t[::8]  # inputs on the fine grid (input times between its points make short steps)
    run = partial(sim.simulate, {}, t_io, {target: u[::8]}, t_io, outputs, feedback)
    native, python = _both(sim, run)
    assert np.all(np.isfinite(native)) and np.max(np.abs(native)) > 0.05
    np.testing.assert_allclose(native, python, rtol=0, atol=1e-12)


def test_native_feedback_raises_the_python_loops_divergence(msd_fmu: Path) -> None:
    runaway = Feedback((FeedbackTerm("f", "x", False, "power", 1e3, 5),), 0.01)
    sim = Simulator(msd_fmu)
    messages: list[str] = []

    def run() -> np.ndarray:
        with pytest.raises(FmuError, match="diverged at t = ") as caught:
            sim.simulate({}, T, {"f": 40 * U}, T, ["x"], runaway)
        messages.append(str(caught.value))
        return np.zeros(1)

    _both(sim, run)
    assert messages[0] == messages[1]


def test_without_a_compiled_loop_the_python_loop_runs(
    msd_fmu: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    blocked = tmp_path / "not-a-folder"
    blocked.write_text("")
    monkeypatch.setenv("FMUID_FMU_DIR", str(blocked))  # the loop cannot be compiled there
    native_library.cache_clear()
    try:
        sim = Simulator(msd_fmu)
        y = sim.simulate({}, T, {"f": U}, T, ["x"])
        again = sim.simulate({}, T, {"f": U}, T, ["x"])
        sim.close()
        assert native_library() is None
    finally:
        native_library.cache_clear()
    warnings = [r for r in caplog.records if "native master loop unavailable" in r.message]
    assert len(warnings) == 1 and "using the Python loop" in warnings[0].message
    np.testing.assert_array_equal(y, again)
    assert np.max(np.abs(y)) > 0.1
