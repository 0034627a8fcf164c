"""Co-simulation master of one run: step the FMU over the plan's grid with its own solver.

The comments naming FMI functions on the lines that call into the FMU are read by
:mod:`fmuid.jobs.crash` to say where a crashing FMU was.

At each communication point the inputs for that time are set before the outputs are read, so a
direct-feedthrough output sees the input of the same instant. Between points the inputs are
linear: FMUs that accept input derivatives (FMI 2.0 ``canInterpolateInputs``) get the slope of
each interval; the others cross each interval where some input changes in equal sub-steps of
at most ``input_step`` seconds, and at most :data:`~fmuid.model.base.MAX_SUB_STEPS` per input
sample interval (a sub-step of at least that interval over it), each holding the linear
input's value at the sub-step's midpoint. The midpoint value makes the held input's integral
over every sub-step exact, so the states' error is second order in the sub-step ``d`` (a local
error of about ``d**3 / 12`` times the input's slope and the system's rate) where the start
value gave a first-order lag of half a sub-step. At the communication
points the FMU sees the exact input values.

The loop runs in compiled code (:mod:`fmuid.model.native`) where it can (Real/Float64 inputs
and outputs, gcc at hand); the Python loop here is the reference it is tested against.
"""

from __future__ import annotations

import math

import numpy as np

from fmuid.model.base import MAX_SUB_STEPS
from fmuid.model.channels import Channels
from fmuid.model.instance import Instance
from fmuid.model.native import run_native_cosimulation
from fmuid.model.plan import RunPlan


def run_cosimulation(
    instance: Instance,
    plan: RunPlan,
    inputs: Channels,
    outputs: Channels,
    input_step: float | None,
    native: bool = True,
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
    native
        Run the compiled loop where it can run (False: always the Python loop).

    Returns
    -------
    result, stopped
        Outputs of shape ``(rows, outputs)`` (rows after a stop are NaN), and the time the FMU
        asked to stop at, or None when it ran to the end.

    """
    if native and (done := run_native_cosimulation(instance, plan, inputs, outputs, input_step)):
        return done
    result = np.full((plan.n_rows, outputs.size), np.nan)
    times, rows_at = plan.times, plan.rows_at
    values, slopes = plan.value.tolist(), plan.slope.tolist()
    sub_step = math.inf if input_step is None else input_step
    moving = [False] * len(times) if input_step is None else np.any(plan.slope, axis=1).tolist()
    segment = plan.segment.tolist()
    moving_inputs = inputs.subset(inputs.continuous)
    fill, set_inputs, set_name = instance.bind_set(inputs)
    get_outputs, out, get_name = instance.bind_get(outputs)
    slope_setter = instance.bind_derivatives(inputs) if input_step is None else None
    step = instance.stepper()
    n_in, last = inputs.size, len(times) - 1
    for k, t in enumerate(times):
        if k and n_in:
            fill(values[k])
            if (status := set_inputs()) > 1:  # fmi2SetReal & co.
                raise instance.fail(set_name, status, f"for the inputs at t = {t} s")
        if slope_setter is not None:
            slope_setter[0](slopes[k])
            if (status := slope_setter[1]()) > 1:  # fmi2SetRealInputDerivatives
                raise instance.fail("fmi2SetRealInputDerivatives", status, f"at t = {t} s")
        if rows := rows_at[k]:
            if (status := get_outputs()) > 1:  # fmi2GetReal & co.
                raise instance.fail(get_name, status, f"at t = {t} s")
            result[rows] = out
        if k == last:
            break
        h = times[k + 1] - t
        if not moving[k]:
            status = step(t, h, 1)  # fmi2DoStep (fmi3DoStep)
            stopped = None if status <= 1 else instance.step_outcome(status, t)
        else:
            value = [values[k][i] for i in inputs.continuous]
            slope = [slopes[k][i] for i in inputs.continuous]
            longest = max(sub_step, segment[k] / MAX_SUB_STEPS)
            stopped = _sub_steps(instance, moving_inputs, value, slope, t, h, longest)
        if stopped is not None:
            if rows_at[k + 1] and stopped >= times[k + 1] - 1e-12 * max(1.0, abs(stopped)):
                result[rows_at[k + 1]] = instance.read(outputs, times[k + 1])
            return result, stopped
    return result, None


def _sub_steps(
    instance: Instance,
    inputs: Channels,
    value: list[float],
    slope: list[float],
    t: float,
    h: float,
    input_step: float,
) -> float | None:
    """Cross ``[t, t + h]`` in equal sub-steps of at most ``input_step``.

    Each sub-step holds the linear input's value at its midpoint; returns the stop time if the
    FMU asks to stop, else None.
    """
    step = instance.stepper()
    n = max(1, math.ceil(h / input_step - 1e-9))
    for j in range(n):
        t_j = t + h * j / n
        t_mid = t + h * (j + 0.5) / n
        instance.set(
            inputs, [v + s * (t_mid - t) for v, s in zip(value, slope, strict=True)], t_mid
        )
        status = step(t_j, t + h * (j + 1) / n - t_j, 1)  # fmi2DoStep (fmi3DoStep)
        if status > 1:
            return instance.step_outcome(status, t_j)
    return None
