"""A model's health without data: whether it runs, repeats a run and keeps its reset.

``fmuid info`` runs the FMU three times at its start values, the inputs held at their start
values, over its default experiment (or one second): a fresh instance, the same instance after
a reset (the simulator compares the two; see :mod:`fmuid.model.simulator`), and once more.
The profile stage's health check (:mod:`fmuid.profiling.health`) goes further with data: the
objective's noise floor and its jumps along each parameter, and reads back with
:func:`held_parameters` the values of parameters that move no output.
"""

from __future__ import annotations

import tempfile
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from fmuid.errors import FmuError
from fmuid.model.channels import Channels
from fmuid.model.fmu import USABLE, FmuModel
from fmuid.model.instance import Instance
from fmuid.model.simulator import Simulator

SAMPLES = 11
"""Output times of each run."""

HORIZON = 1.0
"""Length of the runs [s] when the FMU declares no default experiment."""


@dataclass(frozen=True)
class ModelHealth:
    """What the runs at the start values showed.

    Attributes
    ----------
    simulates
        Whether the runs finished with finite outputs.
    deterministic
        Whether a repeated run gave the same outputs bit for bit (``None`` if it did not run).
    reset_reliable
        Whether a run after a reset equals the run on a fresh instance (``None`` if unknown).
    horizon_s
        Start and stop time of the runs [s].
    message
        What went wrong, or ``""``.
    ignored
        Float parameters the FMU does not hold after initialization when set (each moved by
        1 % from its start value) the way runs set them: it would ignore fmuid's values.

    """

    simulates: bool
    deterministic: bool | None
    reset_reliable: bool | None
    horizon_s: tuple[float, float]
    message: str
    ignored: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON form."""
        return asdict(self)


def model_health(model: FmuModel, stop: float | None) -> ModelHealth:
    """Run the FMU at its start values and report what the runs showed (module docstring)."""
    t0 = 0.0
    t1 = stop if stop is not None and stop > t0 else t0 + HORIZON
    outputs = [n for n, v in model.outputs.items() if v.kind in USABLE["output"]]
    inputs = {
        n: np.full(2, 0.0 if v.start is None else float(v.start))
        for n, v in model.inputs.items()
        if v.kind in USABLE["input"]
    }
    times = np.linspace(t0, t1, SAMPLES)
    horizon = (t0, float(t1))
    simulator: Simulator | None = None
    try:
        simulator = Simulator(model)
        runs = [
            simulator.simulate({}, np.array([t0, t1]), inputs, times, outputs) for _ in range(2)
        ]
    except FmuError as exc:
        return ModelHealth(False, None, None, horizon, str(exc))
    finally:
        if simulator is not None:
            simulator.close()
    finite = all(bool(np.all(np.isfinite(r))) for r in runs)
    same = bool(np.array_equal(runs[0], runs[1], equal_nan=True))
    message = "" if finite else "non-finite outputs at the start values"
    ignored = _ignored(model)
    if ignored:
        message = (
            f"the FMU ignores the parameter(s) {', '.join(ignored)}: set before initialization "
            "as fmuid sets them, it holds other values after it; fits of them would be void"
        )
    return ModelHealth(finite, same, simulator.reset_reliable, horizon, message, ignored)


def _ignored(model: FmuModel) -> tuple[str, ...]:
    """Float parameters whose value moved by 1 % is not held after initialization."""
    moved = {
        name: float(v.start) + max(abs(float(v.start)) * 0.01, 1e-3)
        for name, v in model.parameters.items()
        if v.kind == "float" and isinstance(v.start, int | float)
    }
    if not moved:
        return ()
    try:
        held = held_parameters(model, moved)
    except FmuError:  # moved values the FMU refuses: no verdict
        return ()
    return tuple(n for n, x in moved.items() if not np.isclose(held[n], x, rtol=1e-9, atol=0.0))


def held_parameters(model: FmuModel, values: Mapping[str, float | str]) -> dict[str, float]:
    """Return the parameters' values read back from a fresh instance after initialization.

    The parameters are set as a run sets them (after ``fmi2SetupExperiment``, before
    initialization); an FMU that ignores a value (re-applies its start value, or keeps a
    parameter it never reads from the master) gives back something else. Only numeric
    parameters are read back.

    Raises
    ------
    FmuError
        When the FMU does not load, initialize or give the values back.

    """
    numeric = {n: v for n, v in values.items() if not isinstance(v, str)}
    variables = [model.parameters[n] for n in numeric]
    channels = Channels(variables, model.fmi_version)
    with tempfile.TemporaryDirectory(prefix="fmuid-readback-") as folder:
        model.extract(folder)
        instance = Instance(model, folder)
        try:
            instance.instantiate()
            instance.setup_experiment(0.0, None)
            instance.set(channels, list(numeric.values()), None)
            instance.enter_initialization(0.0, None)
            instance.call("ExitInitializationMode", when="at t = 0.0 s")
            held = instance.read(channels, 0.0)
            return {n: float(held[i]) for i, n in enumerate(numeric)}
        finally:
            instance.unload()
