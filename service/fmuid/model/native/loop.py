"""The native co-simulation master loop (``loop.c``), called through ctypes.

It handles FMUs whose driven inputs and read outputs are all Real (FMI 2.0) or Float64
(FMI 3.0); anything else runs in :func:`fmuid.model.cosim.run_cosimulation`, which stays the
reference. Failures are reported by index and status and turned into the same
:class:`~fmuid.errors.FmuError` (or stop time) as the Python loop gives.
"""

from __future__ import annotations

import ctypes
import math
from typing import Any, cast

import numpy as np

from fmuid.model.base import MAX_SUB_STEPS
from fmuid.model.channels import Channels
from fmuid.model.instance import Instance
from fmuid.model.native.build import native_library
from fmuid.model.plan import RunPlan

_P = ctypes.c_void_p
_LONG = ctypes.c_long
LOOPS_KEPT = 32
"""Loops kept per input channels (one per run plan and outputs, typically)."""
CALL_SET, CALL_DERIVATIVES, CALL_GET, CALL_STEP, CALL_SUB_SET, CALL_GET_SOURCES, DIVERGED = range(7)


class Loop(ctypes.Structure):
    """Mirror of ``FmuidLoop`` in ``loop.c`` (same fields, same order)."""

    _fields_ = [
        ("component", _P),
        ("set_real", _P),
        ("set_derivatives", _P),
        ("do_step", _P),
        ("get_real", _P),
        ("fmi3", ctypes.c_int),
        ("n_times", _LONG),
        ("times", _P),
        ("value", _P),
        ("slope", _P),
        ("moving", _P),
        ("segment", _P),
        ("n_in", _LONG),
        ("in_refs", _P),
        ("n_cont", _LONG),
        ("cont_index", _P),
        ("cont_refs", _P),
        ("orders", _P),
        ("use_derivatives", ctypes.c_int),
        ("sub_step", ctypes.c_double),
        ("max_sub_steps", _LONG),
        ("n_out", _LONG),
        ("out_refs", _P),
        ("row_start", _P),
        ("rows", _P),
        ("result", _P),
        ("work", _P),
        ("fail_k", _LONG),
        ("fail_call", ctypes.c_int),
        ("fail_time", ctypes.c_double),
        ("terminate", ctypes.c_bool),
        ("last_time", ctypes.c_double),
    ]


def _address(instance: Instance, name: str) -> int | None:
    function = instance.f.get(name)
    return None if function is None else ctypes.cast(cast(Any, function), _P).value


def _pointer(array: np.ndarray | ctypes.Array) -> int:  # type: ignore[type-arg]
    if isinstance(array, np.ndarray):
        return int(array.ctypes.data)
    return ctypes.addressof(array)


def supports(instance: Instance, *channels: Channels) -> bool:
    """Whether the native loops can run on this instance with these channels (all float)."""
    return instance.model.is_cosimulation and all(c.all_float or c.size == 0 for c in channels)


def build_loop(
    instance: Instance,
    plan: RunPlan,
    inputs: Channels,
    outputs: Channels,
    derivatives: bool,
    sub_step: float | None,
) -> tuple[Loop, np.ndarray, list[object]]:
    """Return a :class:`Loop` for one run (built once per plan and channels, then reused).

    ``derivatives``: set input slopes (fmi2SetRealInputDerivatives); ``sub_step``: longest
    sub-step of moving intervals (None: never sub-step). Returns the loop, the result array it
    writes (NaN where no row is read) and the objects it points into (keep them alive).
    """
    key = f"native {id(plan)} {id(outputs)} {id(instance)} {derivatives} {sub_step}"
    cached = inputs.helpers.get(key)  # holds plan, outputs and instance: their ids stay theirs
    if cached is None:
        kept = [k for k in inputs.helpers if k.startswith("native ")]
        if len(kept) >= LOOPS_KEPT:
            for old in kept:
                del inputs.helpers[old]
        cached = (
            plan,
            outputs,
            instance,
            *_new_loop(instance, plan, inputs, outputs, derivatives, sub_step),
        )
        inputs.helpers[key] = cached
    loop, alive = cached[3], cached[4]
    component = instance.component
    loop.component = component.value if isinstance(component, _P) else component
    result = np.full((plan.n_rows, outputs.size), np.nan)
    loop.result = _pointer(result)
    return loop, result, alive


def _new_loop(
    instance: Instance,
    plan: RunPlan,
    inputs: Channels,
    outputs: Channels,
    derivatives: bool,
    sub_step: float | None,
) -> tuple[Loop, list[object]]:
    p = instance.prefix
    grid = plan.arrays
    work = np.empty(inputs.size + outputs.size)
    cont = inputs.continuous
    cont_index = np.array(cont, dtype=np.int64)
    cont_refs = inputs.subset(cont).refs
    orders = np.ones(len(cont), dtype=np.int32)
    float_type = "Float64" if instance.v3 else "Real"
    loop = Loop(
        None,
        _address(instance, f"{p}Set{float_type}"),
        _address(instance, "fmi2SetRealInputDerivatives") if derivatives else None,
        _address(instance, f"{p}DoStep"),
        _address(instance, f"{p}Get{float_type}"),
        int(instance.v3),
        plan.grid.size,
        _pointer(grid.times),
        _pointer(grid.value),
        _pointer(grid.slope),
        None if sub_step is None else _pointer(grid.moving),
        _pointer(grid.segment),
        inputs.size,
        _pointer(inputs.refs),
        len(cont),
        _pointer(cont_index),
        _pointer(cont_refs),
        _pointer(orders),
        int(derivatives),
        math.inf if sub_step is None else sub_step,
        MAX_SUB_STEPS,
        outputs.size,
        _pointer(outputs.refs),
        _pointer(grid.row_start),
        _pointer(grid.rows),
        None,
        _pointer(work),
    )
    return loop, [grid, work, cont_index, cont_refs, orders]


def run_native_cosimulation(
    instance: Instance,
    plan: RunPlan,
    inputs: Channels,
    outputs: Channels,
    input_step: float | None,
) -> tuple[np.ndarray, float | None] | None:
    """Run :func:`fmuid.model.cosim.run_cosimulation`'s loop in C; None when it cannot.

    Parameters and returns are those of :func:`~fmuid.model.cosim.run_cosimulation`; None means
    the caller runs the Python loop (see :func:`supports`).

    Raises
    ------
    FmuError
        As the Python loop does, for a call that returns neither OK nor Warning.

    """
    lib = native_library()
    if lib is None or not supports(instance, inputs, outputs):
        return None
    loop, result, _alive = build_loop(
        instance, plan, inputs, outputs, input_step is None, input_step
    )
    status = lib.fmuid_cosimulation(ctypes.byref(loop))  # fmi2DoStep fmi3DoStep (and get/set)
    if not status:
        return result, None
    stopped = failure(instance, plan, inputs, outputs, loop, status)
    following = float(plan.grid[loop.fail_k + 1])
    if plan.rows_at[loop.fail_k + 1] and stopped >= following - 1e-12 * max(1.0, abs(stopped)):
        result[plan.rows_at[loop.fail_k + 1]] = instance.read(outputs, following)
    return result, stopped


def failure(
    instance: Instance,
    plan: RunPlan,
    inputs: Channels,
    outputs: Channels,
    loop: Loop,
    status: int,
) -> float:
    """Raise the Python loop's error for the failed call, or return the stop time asked for."""
    k, call = loop.fail_k, loop.fail_call
    t = float(plan.grid[k])
    if call in (CALL_SET, CALL_SUB_SET):
        when = t if call == CALL_SET else loop.fail_time
        raise instance.fail(inputs.setters[0], status, f"for the inputs at t = {when} s")
    if call == CALL_DERIVATIVES:
        raise instance.fail("fmi2SetRealInputDerivatives", status, f"at t = {t} s")
    if call == CALL_GET:
        raise instance.fail(outputs.getters[0], status, f"at t = {t} s")
    if not instance.v3:
        return instance.step_outcome(status, loop.fail_time)
    if status == 2 and loop.terminate:
        return float(loop.last_time)
    raise instance.fail("fmi3DoStep", status, f"in the step from t = {loop.fail_time} s")
