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

from fmuid.model.channels import Channels
from fmuid.model.instance import Instance
from fmuid.model.native.build import native_library
from fmuid.model.plan import RunPlan

_P = ctypes.c_void_p
_LONG = ctypes.c_long
CALL_SET, CALL_DERIVATIVES, CALL_GET, CALL_STEP, CALL_SUB_SET = range(5)


class Loop(ctypes.Structure):
    """Mirror of ``FmuidLoop`` in ``loop.c`` (same fields, same order)."""

    _fields_ = [
        ("component", _P), ("set_real", _P), ("set_derivatives", _P), ("do_step", _P),
        ("get_real", _P), ("fmi3", ctypes.c_int), ("n_times", _LONG), ("times", _P),
        ("value", _P), ("slope", _P), ("moving", _P), ("n_in", _LONG), ("in_refs", _P),
        ("n_cont", _LONG), ("cont_index", _P), ("cont_refs", _P), ("orders", _P),
        ("use_derivatives", ctypes.c_int), ("sub_step", ctypes.c_double), ("n_out", _LONG),
        ("out_refs", _P), ("row_start", _P), ("rows", _P), ("result", _P), ("work", _P),
        ("fail_k", _LONG), ("fail_call", ctypes.c_int), ("fail_time", ctypes.c_double),
        ("terminate", ctypes.c_bool), ("last_time", ctypes.c_double),
    ]  # fmt: skip


def _address(instance: Instance, name: str) -> int | None:
    function = instance.f.get(name)
    return None if function is None else ctypes.cast(cast(Any, function), _P).value


def _pointer(array: np.ndarray | ctypes.Array) -> int:  # type: ignore[type-arg]
    if isinstance(array, np.ndarray):
        return int(array.ctypes.data)
    return ctypes.addressof(array)


def supports(instance: Instance, inputs: Channels, outputs: Channels) -> bool:
    """Whether the native loop can run these channels on this instance."""
    return (
        instance.model.is_cosimulation
        and (inputs.all_float or inputs.size == 0)
        and (outputs.all_float or outputs.size == 0)
        and native_library() is not None
    )


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
    if not supports(instance, inputs, outputs):
        return None
    lib = native_library()
    assert lib is not None
    p = instance.prefix
    grid = plan.arrays
    n_times = len(plan.times)
    result = np.full((plan.n_rows, outputs.size), np.nan)
    work = np.empty(inputs.size + outputs.size)
    cont = inputs.continuous
    cont_index = np.array(cont, dtype=np.int64)
    cont_refs = inputs.subset(cont).refs
    orders = np.ones(len(cont), dtype=np.int32)
    float_type = "Float64" if instance.v3 else "Real"
    loop = Loop(
        instance.component.value if isinstance(instance.component, _P) else instance.component,
        _address(instance, f"{p}Set{float_type}"),
        _address(instance, "fmi2SetRealInputDerivatives") if input_step is None else None,
        _address(instance, f"{p}DoStep"), _address(instance, f"{p}Get{float_type}"),
        int(instance.v3), n_times, _pointer(grid.times), _pointer(grid.value),
        _pointer(grid.slope), None if input_step is None else _pointer(grid.moving),
        inputs.size, _pointer(inputs.refs), len(cont), _pointer(cont_index),
        _pointer(cont_refs), _pointer(orders), int(input_step is None),
        math.inf if input_step is None else input_step, outputs.size,
        _pointer(outputs.refs), _pointer(grid.row_start), _pointer(grid.rows),
        _pointer(result), _pointer(work),
    )  # fmt: skip
    status = lib.fmuid_cosimulation(ctypes.byref(loop))  # fmi2DoStep fmi3DoStep (and get/set)
    if not status:
        return result, None
    return result, _failure(instance, plan, inputs, outputs, loop, status, result)


def _failure(
    instance: Instance, plan: RunPlan, inputs: Channels, outputs: Channels, loop: Loop,
    status: int, result: np.ndarray,
) -> float:  # fmt: skip
    """Raise the Python loop's error for the failed call, or return the stop time it asked."""
    k, call = loop.fail_k, loop.fail_call
    t = plan.times[k]
    if call in (CALL_SET, CALL_SUB_SET):
        when = t if call == CALL_SET else loop.fail_time
        raise instance.fail(inputs.setters[0], status, f"for the inputs at t = {when} s")
    if call == CALL_DERIVATIVES:
        raise instance.fail("fmi2SetRealInputDerivatives", status, f"at t = {t} s")
    if call == CALL_GET:
        raise instance.fail(outputs.getters[0], status, f"at t = {t} s")
    if not instance.v3:
        stopped = instance.step_outcome(status, loop.fail_time)
    elif status == 2 and loop.terminate:
        stopped = float(loop.last_time)
    else:
        raise instance.fail("fmi3DoStep", status, f"in the step from t = {loop.fail_time} s")
    following = plan.times[k + 1]
    if plan.rows_at[k + 1] and stopped >= following - 1e-12 * max(1.0, abs(stopped)):
        result[plan.rows_at[k + 1]] = instance.read(outputs, following)
    return stopped
