"""Simulator: reuse after reset, input handling, error paths, per-process cache."""

from __future__ import annotations

import multiprocessing
from pathlib import Path

import numpy as np
import pytest

from fmuid.errors import FmuError
from fmuid.model.kept import MAX_BYTES, array_bytes
from fmuid.model.registry import get_simulator
from fmuid.model.simulator import Simulator

from .reference import OUTPUT_TIME, RAMP_DELTA, RAMP_TIME
from .test_msd import step_response

OUTS = ["gam_t", "gam_i", "x_ic"]


@pytest.fixture(scope="module")
def tractor(tractor_fmu: Path):
    sim = Simulator(tractor_fmu)
    yield sim
    sim.close()


def _ramp(sim: Simulator, params: dict[str, float]) -> np.ndarray:
    return sim.simulate(params, RAMP_TIME, {"delta": RAMP_DELTA}, OUTPUT_TIME, OUTS)


def test_reuse_after_reset_is_exact(tractor: Simulator) -> None:
    first = _ramp(tractor, {})
    np.testing.assert_array_equal(_ramp(tractor, {}), first)
    other = _ramp(tractor, {"C_atf": 50000.0, "sig_ir": 1.7, "alpha_sat": 0.03})
    assert np.max(np.abs(other - first)) > 1e-3
    np.testing.assert_array_equal(_ramp(tractor, {}), first)


def test_unset_parameters_keep_start_values(tractor: Simulator) -> None:
    # a value set in one run does not leak into the next run of the same instance
    before = _ramp(tractor, {})
    changed = _ramp(tractor, {"C_atf": 150000.0})
    assert np.max(np.abs(changed - before)) > 1e-4
    np.testing.assert_array_equal(_ramp(tractor, {}), before)


def test_output_order_and_duplicates(tractor: Simulator) -> None:
    full = _ramp(tractor, {})
    t = OUTPUT_TIME[[5, 0, 5, 50]]
    y = tractor.simulate({}, RAMP_TIME, {"delta": RAMP_DELTA}, t, ["x_ic", "gam_t"])
    # another communication grid: the FMU's error-controlled steps differ within its tolerance
    np.testing.assert_allclose(y, full[[5, 0, 5, 50]][:, [2, 0]], rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(y[0], y[2])
    assert y[1, 1] == 0.0


def test_input_held_constant_outside_samples(msd_fmu: Path) -> None:
    sim = Simulator(msd_fmu)
    try:
        t = OUTPUT_TIME
        held = sim.simulate({}, np.array([0.0, 0.5]), {"f": np.array([40.0, 40.0])}, t, ["x"])
        single = sim.simulate({}, np.array([0.0]), {"f": np.array([40.0])}, t, ["x"])
        step = sim.simulate({}, np.array([0.0, 0.0]), {"f": np.array([0.0, 40.0])}, t, ["x"])
    finally:
        sim.close()
    x, _ = step_response(1.1, 4.4, 1.6, 40.0, t)
    for y in (held, single, step):
        np.testing.assert_allclose(y[:, 0], x, rtol=0, atol=1e-8)


def test_unknown_names_raise_clear_errors(tractor: Simulator) -> None:
    with pytest.raises(FmuError, match="no parameter named 'C_xyz'.*C_atf"):
        tractor.simulate({"C_xyz": 1.0}, RAMP_TIME, {"delta": RAMP_DELTA}, OUTPUT_TIME, OUTS)
    with pytest.raises(FmuError, match="no input named 'steer'"):
        tractor.simulate({}, RAMP_TIME, {"steer": RAMP_DELTA}, OUTPUT_TIME, OUTS)
    with pytest.raises(FmuError, match="no output named 'yaw'"):
        tractor.simulate({}, RAMP_TIME, {"delta": RAMP_DELTA}, OUTPUT_TIME, ["yaw"])
    with pytest.raises(ValueError, match="non-decreasing"):
        tractor.simulate({}, RAMP_TIME[::-1], {"delta": RAMP_DELTA}, OUTPUT_TIME, OUTS)


def test_fmi_error_raises_and_instance_recovers(tractor: Simulator) -> None:
    with pytest.raises(FmuError, match="sig_tf must be > 0") as info:
        _ramp(tractor, {"sig_tf": 0.0})
    assert info.value.function == "fmi2ExitInitializationMode"
    assert info.value.status == "fmi2Error"
    assert "tractor_implement" in str(info.value)
    with pytest.raises(FmuError, match="not finite") as info:
        _ramp(tractor, {"C_atf": float("nan")})
    assert info.value.function == "fmi2SetReal"
    with pytest.raises(FmuError, match="too stiff") as info:
        _ramp(tractor, {"sig_tf": 1e-9})
    assert info.value.function == "fmi2DoStep"
    assert "t = " in str(info.value)
    np.testing.assert_array_equal(_ramp(tractor, {}), _ramp(tractor, {}))


def test_get_simulator_caches_per_path(msd_fmu: Path) -> None:
    first = get_simulator(msd_fmu)
    assert get_simulator(str(msd_fmu)) is first
    assert first.model.model_name == "msd"


def test_a_forked_child_leaves_the_parents_fmu_files(msd_fmu: Path, msd_parallel_fmu: Path) -> None:
    """A forked worker drops the simulators it inherits; the parent's extracted FMU stays."""
    unzip_dir = Path(get_simulator(msd_fmu)._unzip_dir)

    def child() -> None:
        get_simulator(msd_parallel_fmu)  # a new pid: the inherited cache is dropped

    process = multiprocessing.get_context("fork").Process(target=child)
    process.start()
    process.join()
    assert process.exitcode == 0
    assert (unzip_dir / "modelDescription.xml").is_file()


def test_plan_reuse_sees_arrays_changed_in_place(tractor: Simulator) -> None:
    delta = RAMP_DELTA.copy()
    first = tractor.simulate({}, RAMP_TIME, {"delta": delta}, OUTPUT_TIME, OUTS)
    delta *= 2.0
    doubled = tractor.simulate({}, RAMP_TIME, {"delta": delta}, OUTPUT_TIME, OUTS)
    np.testing.assert_allclose(doubled[:, 0], 2.0 * first[:, 0], rtol=1e-9, atol=1e-15)
    fresh = tractor.simulate({}, RAMP_TIME, {"delta": 2.0 * RAMP_DELTA}, OUTPUT_TIME, OUTS)
    np.testing.assert_array_equal(doubled, fresh)


def test_run_plans_stay_within_their_byte_bound(tractor: Simulator) -> None:
    """New input arrays at every run (an input effect) keep at most the plans the bound holds."""
    plans = tractor._plans
    plans._values.clear()
    _ramp(tractor, {})
    ((one, size),) = plans._values.values()
    assert size == array_bytes(one) > 0
    plans.max_bytes = int(2.5 * size)
    try:
        for k in range(5):
            tractor.simulate({}, RAMP_TIME, {"delta": RAMP_DELTA + k}, OUTPUT_TIME, OUTS)
        assert len(plans._values) == 2
        assert all(b == array_bytes(e) for e, b in plans._values.values())
    finally:
        plans.max_bytes = MAX_BYTES
