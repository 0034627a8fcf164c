"""The native closed loop (``fmuid_feedback`` in ``loop.c``) of :mod:`fmuid.model.feedback`.

The Python :func:`fmuid.model.feedback.run_feedback` stays the reference; this runs the same
arithmetic in C where the driven inputs, the outputs read and the terms' sources are all
Real/Float64, and gives the same errors.
"""

from __future__ import annotations

import ctypes

import numpy as np

from fmuid.model.channels import Channels
from fmuid.model.feedback import KINDS, Feedback, diverged
from fmuid.model.instance import Instance
from fmuid.model.native.build import native_library
from fmuid.model.native.loop import CALL_GET_SOURCES, DIVERGED, build_loop, failure, supports
from fmuid.model.plan import RunPlan

_P = ctypes.c_void_p


class Terms(ctypes.Structure):
    """Mirror of ``FmuidTerms`` in ``loop.c`` (same fields, same order)."""

    _fields_ = [
        ("n_src", ctypes.c_long),
        ("src_refs", _P),
        ("n_terms", ctypes.c_long),
        ("input", _P),
        ("source", _P),
        ("derivative", _P),
        ("kind", _P),
        ("coefficient", _P),
        ("shape", _P),
        ("level", _P),
        ("previous", _P),
        ("g", _P),
        ("g_prev", _P),
        ("rate", _P),
        ("trend", _P),
        ("min_gap", ctypes.c_double),
    ]


def run_native_feedback(
    instance: Instance,
    plan: RunPlan,
    inputs: Channels,
    outputs: Channels,
    sources: Channels,
    feedback: Feedback,
    interpolate: bool,
) -> tuple[np.ndarray, float | None] | None:
    """Run :func:`fmuid.model.feedback.run_feedback` in C; None when it cannot (then run that).

    Parameters and returns are those of :func:`~fmuid.model.feedback.run_feedback`.

    Raises
    ------
    FmuError
        As the Python loop does: a failed FMI call, or a loop the terms drove beyond the float
        range.

    """
    lib = native_library()
    if lib is None or not supports(instance, inputs, outputs, sources):
        return None
    names = [v.name for v in inputs.variables]
    src_names = [v.name for v in sources.variables]
    terms = feedback.terms
    arrays: list[np.ndarray] = [
        np.array([names.index(t.input) for t in terms], dtype=np.int64),
        np.array([src_names.index(t.source) for t in terms], dtype=np.int64),
        np.array([t.derivative for t in terms], dtype=np.int32),
        np.array([KINDS.index(t.kind) for t in terms], dtype=np.int32),
        np.array([t.coefficient for t in terms], dtype=np.float64),
        np.array([int(t.shape) if t.kind == "power" else t.shape for t in terms], dtype=float),
        np.zeros(sources.size),
        np.zeros(sources.size),
        np.zeros(inputs.size),
        np.zeros(inputs.size),
        np.zeros(sources.size),
        np.zeros(inputs.size),
    ]
    spec = Terms(
        sources.size,
        ctypes.addressof(sources.refs),
        len(terms),
        *(int(a.ctypes.data) for a in arrays),
        feedback.min_gap,
    )
    loop, result, _alive = build_loop(instance, plan, inputs, outputs, interpolate, None)
    status = lib.fmuid_feedback(ctypes.byref(loop), ctypes.byref(spec))  # fmi2DoStep fmi3DoStep
    if not status:
        return result, None
    t = float(plan.grid[loop.fail_k])
    if loop.fail_call == DIVERGED:
        raise diverged(t)
    if loop.fail_call == CALL_GET_SOURCES:
        raise instance.fail(sources.getters[0], status, f"at t = {t} s")
    return result, failure(instance, plan, inputs, outputs, loop, status)
