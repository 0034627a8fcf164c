"""What every simulator of an FMU has: the parsed model and how inputs reach it."""

from __future__ import annotations

from pathlib import Path

from fmuid.model.exchange import RTOL
from fmuid.model.fmu import FmuModel, model_of_file

INPUT_STEP = 1e-3
"""Default longest sub-step [s] over which a co-simulation FMU without input derivatives holds
an input (the linear input's value at each sub-step's midpoint)."""

MAX_SUB_STEPS = 8
"""Most sub-steps per input sample interval, whatever :data:`INPUT_STEP` asks (a sub-step is
at least the sample interval over this): the hold's error is second order in the sub-step, so
8 leave 1/64 of a single hold's, while the input itself is only known at its samples (its
linear interpolation is second order in the sample interval). A process sampled every 4 s
would otherwise cost 4,000 FMU steps per sample."""


def as_model(fmu: FmuModel | str | Path, interface: str | None = None) -> FmuModel:
    """Return ``fmu`` driving ``interface`` (None: as it is).

    A path gives this process's model of the file (:func:`~fmuid.model.fmu.model_of_file`).
    """
    if isinstance(fmu, FmuModel):
        return fmu if interface is None else fmu.with_interface(interface)
    return model_of_file(fmu, interface)


class SimulatorBase:
    """What every simulator of an FMU has: the parsed FMU and how inputs reach it.

    Parameters
    ----------
    fmu
        The parsed FMU (:class:`FmuModel`), or a ``.fmu`` file to parse.
    interface
        ``"co_simulation"``, ``"model_exchange"`` or ``"auto"`` (as :class:`FmuModel`); None:
        the model's own (for a file: auto).
    input_step
        Longest sub-step [s] for co-simulation FMUs without input derivatives.

    """

    def __init__(
        self,
        fmu: FmuModel | str | Path,
        interface: str | None = None,
        input_step: float = INPUT_STEP,
    ) -> None:
        self.model = as_model(fmu, interface)
        self.path = self.model.path
        self.input_step = float(input_step)

    @property
    def input_handling(self) -> str:
        """How inputs reach this FMU between their samples (for results and logs)."""
        model = self.model
        if not model.is_cosimulation:
            return f"model exchange: linear inputs set at every CVode evaluation (rtol {RTOL:g})"
        if model.can_interpolate_inputs:
            return "co-simulation with input derivatives (fmi2SetRealInputDerivatives)"
        return (
            f"co-simulation, linear inputs held over sub-steps of at most {self.input_step:g} s "
            f"(at most {MAX_SUB_STEPS} per input sample interval) at each sub-step's midpoint value"
        )
