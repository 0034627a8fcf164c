"""Foreign FMUs (Modelica Reference-FMUs, FMI 2.0 and 3.0, co-simulation and model exchange).

Each is simulated by fmuid's Simulator and compared with ``fmpy.simulate_fmu`` and, where the
equations are known, with closed forms or scipy's ``solve_ivp``.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import fmpy
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.errors import FmuError
from fmuid.model import fmu as fmu_module
from fmuid.model.channels import Channels
from fmuid.model.instance import Instance
from fmuid.model.simulator import Simulator

from .foreign import model_exchange_only, reference_fmu

CS, ME = "CoSimulation", "ModelExchange"
KINDS = [(v, i) for v in ("fmi2", "fmi3") for i in (CS, ME)]
OUTPUTS = {
    "VanDerPol": ["x0", "x1"],
    "Dahlquist": ["x"],
    "BouncingBall": ["h", "v"],
    "Stair": ["counter"],
    "Resource": ["y"],
}
T = np.round(np.arange(0, 3.0 + 1e-9, 0.1), 10)


def _simulator(version: str, name: str, interface: str) -> Simulator:
    return Simulator(reference_fmu(version, name), interface=interface)


@pytest.mark.parametrize("name", sorted(OUTPUTS))
@pytest.mark.parametrize(("version", "interface"), KINDS)
def test_simulates_like_fmpy(version: str, interface: str, name: str) -> None:
    if version == "fmi3" and name == "Resource":
        reference_fmu("fmi3", "Resource")  # not built for FMI 3.0: skips with the reason
    sim = _simulator(version, name, interface)
    outputs = OUTPUTS[name]
    y = sim.simulate({}, np.array([0.0]), {}, T, outputs)
    me = interface == ME
    ref = fmpy.simulate_fmu(
        str(sim.path),
        fmi_type=interface,
        stop_time=T[-1],
        output_interval=0.1,
        relative_tolerance=1e-10 if me else None,
        output=outputs,
    )
    expected = np.column_stack([np.interp(T, ref["time"], ref[o]) for o in outputs])
    if name == "BouncingBall" and me:  # fmpy records both sides of each bounce
        _, last = np.unique(ref["time"], return_index=True)
        expected = np.column_stack(
            [ref[o][last][np.searchsorted(ref["time"][last], T)] for o in outputs]
        )
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-5 if me else 1e-12)
    assert sim.reset_reliable
    np.testing.assert_array_equal(sim.simulate({}, np.array([0.0]), {}, T, outputs), y)
    sim.close()


@pytest.mark.parametrize(("version", "interface"), KINDS)
def test_dahlquist_closed_form(version: str, interface: str) -> None:
    sim = _simulator(version, "Dahlquist", interface)
    t = np.linspace(0.0, 10.0, 101)
    x = sim.simulate({"k": 1.5}, np.array([0.0]), {}, t, ["x"])[:, 0]
    if interface == CS:  # the FMU's own forward Euler with its fixed 0.1 s step
        np.testing.assert_allclose(x, (1 - 0.15) ** np.round(t / 0.1), rtol=0, atol=1e-14)
    else:
        np.testing.assert_allclose(x, np.exp(-1.5 * t), rtol=0, atol=5e-7)


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_van_der_pol_model_exchange_against_solve_ivp(version: str) -> None:
    sim = _simulator(version, "VanDerPol", ME)
    t = np.linspace(0.0, 10.0, 51)
    y = sim.simulate({"mu": 1.3}, np.array([0.0]), {}, t, ["x0", "x1"])
    sol = solve_ivp(
        lambda _, x: [x[1], 1.3 * (1 - x[0] ** 2) * x[1] - x[0]],
        (0, 10),
        [2.0, 0.0],
        t_eval=t,
        rtol=1e-12,
        atol=1e-12,
        method="DOP853",
    )
    np.testing.assert_allclose(y, sol.y.T, rtol=0, atol=1e-5)


def test_model_exchange_only_fmu_is_driven_by_cvode() -> None:
    sim = Simulator(reference_fmu("fmi2", "VanDerPol_ME_only"))
    assert sim.model.interface == ME
    assert "model exchange" in sim.input_handling
    both = _simulator("fmi2", "VanDerPol", ME)
    t = np.linspace(0.0, 5.0, 26)
    np.testing.assert_array_equal(
        sim.simulate({"mu": 0.7}, t[:1], {}, t, ["x0"]),
        both.simulate({"mu": 0.7}, t[:1], {}, t, ["x0"]),
    )


@pytest.mark.parametrize(("version", "interface"), KINDS)
def test_feedthrough_reproduces_a_ramp_and_every_type(version: str, interface: str) -> None:
    sim = _simulator(version, "Feedthrough", interface)
    if interface == CS:
        assert "held over sub-steps" in sim.input_handling
    t_in = np.array([0.0, 1.0, 2.0, 2.0, 3.0])
    inputs = {
        "Float64_continuous_input": np.array([0.0, 1.0, 1.0, -2.0, 0.5]),
        "Int32_input": np.array([3.0, 4.0, 4.0, -7.0, -7.0]),
        "Boolean_input": np.array([0.0, 1.0, 1.0, 0.0, 0.0]),
        "Enumeration_input": np.array([1.0, 2.0, 2.0, 1.0, 1.0]),
        "Float64_discrete_input": np.array([5.0, 6.0, 6.0, 7.0, 7.0]),
    }
    outputs = [name.replace("input", "output") for name in inputs]
    t = np.round(np.arange(0, 3.0 + 1e-9, 0.05), 10)
    y = sim.simulate({"Float64_tunable_parameter": 2.0}, t_in, inputs, t, outputs)
    ramp = np.where(t < 2, np.interp(t, [0, 1, 2], [0, 1, 1]), -2.0 + 2.5 * (t - 2))
    np.testing.assert_allclose(y[:, 0], ramp, rtol=0, atol=1e-9)
    held = np.searchsorted(t_in, t, side="right") - 1
    for j, name in enumerate(list(inputs)[1:], start=1):
        np.testing.assert_array_equal(y[:, j], inputs[name][held], err_msg=name)


@pytest.mark.parametrize(("version", "interface"), KINDS)
def test_stair_stops_at_nine_seconds(version: str, interface: str) -> None:
    sim = _simulator(version, "Stair", interface)
    t = np.arange(0.0, 9.0 + 1e-9, 0.5)
    y = sim.simulate({}, t[:1], {}, t, ["counter"])[:, 0]
    np.testing.assert_array_equal(y[:-1], 1 + np.floor(t[:-1]))
    assert y[-1] == 10  # the FMU's value where it asked to stop
    with pytest.raises(FmuError, match=r"stopped the simulation at t = 9\.0 s.*up to t = 10\.0"):
        sim.simulate({}, t[:1], {}, np.linspace(0, 10, 11), ["counter"])
    np.testing.assert_array_equal(sim.simulate({}, t[:1], {}, t, ["counter"])[:, 0], y)


def test_unusable_types_are_named() -> None:
    sim = _simulator("fmi3", "Feedthrough", CS)
    t = np.array([0.0, 1.0])
    with pytest.raises(FmuError, match="'String_output' is of type String"):
        sim.simulate({}, t[:1], {}, t, ["String_output"])
    with pytest.raises(FmuError, match="'Binary_input' is of type Binary"):
        sim.simulate({}, t[:1], {"Binary_input": np.zeros(1)}, t, ["Int8_output"])
    with pytest.raises(FmuError, match="'Int32_input' .*whole numbers; got 0.5 at t = 1.0 s"):
        sim.simulate({}, t, {"Int32_input": np.array([0.0, 0.5])}, t, ["Int32_output"])
    with pytest.raises(FmuError, match="'Float64_tunable_parameter' is Float64; got the text"):
        sim.simulate({"Float64_tunable_parameter": "x"}, t[:1], {}, t, ["Int32_output"])
    space = Simulator(reference_fmu("fmi3", "StateSpace"))
    with pytest.raises(FmuError, match="'y' is of type Float64 array"):
        space.simulate({}, t[:1], {}, t, ["y"])


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_string_values_are_set_as_text(version: str) -> None:
    sim = _simulator(version, "Feedthrough", CS)
    instance = sim._start()
    channels = Channels([sim.model.inputs["String_input"]], sim.model.fmi_version)
    instance.set(channels, ["hello"], None)
    instance.enter_initialization(0.0, None)
    instance.call("ExitInitializationMode")
    ref = (ctypes.c_uint * 1)(sim.model.outputs["String_output"].value_reference)
    text = (ctypes.c_char_p * 1)()
    extra = (1,) if version == "fmi3" else ()
    assert instance.f[instance.prefix + "GetString"](instance.component, ref, 1, text, *extra) == 0
    assert text[0] == b"hello"
    with pytest.raises(FmuError, match="'String_input' is a String; give it a text value"):
        instance.set(channels, [1.0], None)


def test_usage_problems_name_field_and_type() -> None:
    model = fmu_module.FmuModel(reference_fmu("fmi2", "Feedthrough"))
    problems = model.usage_problems(
        ["Float64_tunable_parameter"],
        {"Float64_fixed_parameter": "text"},
        ["String_input"],
        ["Int32_output", "String_output"],
    )
    assert problems == [
        "inputs.String_input: 'String_input' is a String input, which fmuid cannot use there "
        "(inputs must be Real/Float, Integer, Enumeration or Boolean scalars)",
        "outputs.String_output: 'String_output' is a String output, which fmuid cannot use "
        "there (outputs must be Real/Float, Integer, Enumeration or Boolean scalars)",
        "fixed.Float64_fixed_parameter: 'Float64_fixed_parameter' is a Real parameter; 'text' "
        "does not fit (give it a number)",
    ]


def test_unreliable_reset_is_detected(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(Instance, "reset", lambda self: True)  # a reset that resets nothing
    sim = _simulator("fmi2", "Dahlquist", CS)
    t = np.linspace(0.0, 1.0, 11)
    first = sim.simulate({"k": 2.0}, t[:1], {}, t, ["x"])
    assert sim.reset_reliable is False
    before = sim._instance.instantiations
    np.testing.assert_array_equal(sim.simulate({"k": 2.0}, t[:1], {}, t, ["x"]), first)
    assert sim._instance.instantiations == before + 1


def test_fmi3_model_exchange_copy(tmp_path: Path) -> None:
    path = model_exchange_only(reference_fmu("fmi3", "VanDerPol"), tmp_path / "vdp_me.fmu")
    assert Simulator(path).model.kind_label == "FMI 3.0 model exchange"
