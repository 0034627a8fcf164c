"""Co-simulation master of one run: step the FMU over the plan's grid with its own solver.

At each communication point the inputs for that time are set before the outputs are read, so a
direct-feedthrough output sees the input of the same instant. Between points the inputs are
linear: FMUs that accept input derivatives (FMI 2.0 ``canInterpolateInputs``) get the slope of
each interval; the others get the linear input sampled every ``input_step`` seconds and held
over each sub-step (only on intervals where some input changes).
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from fmuid.model.instance import Channels, Instance
from fmuid.model.plan import RunPlan


def run_cosimulation(
    instance: Instance,
    plan: RunPlan,
    inputs: Channels,
    outputs: Channels,
    input_step: float | None,
) -> tuple[np.ndarray, float | None]:
    """Step an initialized FMU over the grid and read the outputs.

    Parameters
    ----------
    instance
        An instance that has left initialization mode at ``plan.times[0]`` with the inputs of
        that time set.
    plan
        The grid, inputs and output rows.
    inputs, outputs
        The driven inputs and the outputs read.
    input_step
        Longest sub-step [s] over which a non-interpolating FMU holds an input; None when the
        FMU gets input derivatives instead.

    Returns
    -------
    result, stopped
        Outputs of shape ``(rows, outputs)`` (rows after a stop are NaN), and the time the FMU
        asked to stop at, or None when it ran to the end.

    """
    result = np.full((plan.n_rows, outputs.size), np.nan)
    times, rows_at = plan.times, plan.rows_at
    values, slopes = plan.value.tolist(), plan.slope.tolist()
    index = inputs.continuous
    derivatives = None
    if input_step is None and index:
        derivatives = inputs.helpers.get("derivatives") or _Derivatives(inputs)
        inputs.helpers["derivatives"] = derivatives
    sub_step = math.inf if input_step is None else input_step
    moving = [False] * len(times) if input_step is None else np.any(plan.slope, axis=1).tolist()
    moving_inputs = inputs.subset(index)
    do_step, write, read = instance.stepper(), instance.writer(inputs), instance.reader(outputs)
    write_moving = instance.writer(moving_inputs)
    for k, t in enumerate(times):
        if k and inputs.size:
            write(values[k], t)
        if derivatives is not None:
            derivatives.set(instance, slopes[k], t)
        if rows_at[k]:
            result[rows_at[k]] = read(t)
        if k + 1 == len(times):
            return result, None
        h = times[k + 1] - t
        if not moving[k] or h <= sub_step:
            stopped = do_step(t, h)
        else:
            value = [values[k][i] for i in index]
            slope = [slopes[k][i] for i in index]
            stopped = _sub_steps(do_step, write_moving, value, slope, t, h, sub_step)
        if stopped is not None:
            if rows_at[k + 1] and stopped >= times[k + 1] - 1e-12 * max(1.0, abs(stopped)):
                result[rows_at[k + 1]] = read(times[k + 1])
            return result, stopped
    return result, None


def _sub_steps(
    step: Callable[[float, float], float | None],
    write: Callable[[Sequence[float], float], None],
    value: list[float],
    slope: list[float],
    t: float,
    h: float,
    input_step: float,
) -> float | None:
    """Cross ``[t, t + h]`` in equal sub-steps of at most ``input_step``.

    Each sub-step holds the linear input's value at its start; returns the stop time if the FMU
    asks to stop, else None.
    """
    n = math.ceil(h / input_step - 1e-9)
    for j in range(n):
        t_j = t + h * j / n
        if j:
            write([v + s * (t_j - t) for v, s in zip(value, slope, strict=True)], t_j)
        stopped = step(t_j, t + h * (j + 1) / n - t_j)
        if stopped is not None:
            return stopped
    return None


class _Derivatives:
    """``fmi2SetRealInputDerivatives`` of the float inputs, buffers made once per run."""

    def __init__(self, inputs: Channels) -> None:
        self.index = inputs.continuous
        n = len(self.index)
        self.refs = (ctypes.c_uint * n)(*(inputs.variables[i].value_reference for i in self.index))
        self.order = (ctypes.c_int * n)(*([1] * n))
        self.der = (ctypes.c_double * n)()
        self.identity = n == inputs.size

    def set(self, instance: Instance, slope: list[float], t: float) -> None:
        """Give the FMU the input slopes of the interval that starts at ``t``."""
        n = len(self.index)
        values: list[Any] = slope if self.identity else [slope[i] for i in self.index]
        self.der[:] = values
        status = instance.f["fmi2SetRealInputDerivatives"](
            instance.component, self.refs, n, self.order, self.der
        )
        if status > 1:
            raise instance.fail("fmi2SetRealInputDerivatives", status, f"at t = {t} s")
