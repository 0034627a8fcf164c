"""Model-exchange master of one run: SUNDIALS CVode (through fmpy) with event handling.

Tolerances are fixed so that each run is a deterministic function of the parameters:
relative tolerance :data:`RTOL`, absolute tolerance ``RTOL`` times each state's nominal value
(fmpy's convention), BDF with a dense Newton solver, largest step 1/50 of the run. Float inputs
are linear in time and set at every time the solver evaluates the model (exact, no sub-steps);
at an input breakpoint the solver restarts, and where an input jumps (or an integer/Boolean
input changes) the FMU goes through event mode. Time, state and step events are handled as the
FMI standard describes; a ``terminateSimulation`` request ends the run at its time.

Nominals the FMU gives that are not positive and finite (Dymola's are 0) would make CVode's
tolerances zero or negative; they are replaced by ``max(|x|, 1)`` of the state at that time,
and the log says so once per instance. A failure of CVode becomes one :class:`FmuError` naming
the FMU, the time span and SUNDIALS' message (SUNDIALS' own line on stderr is silenced).
"""

from __future__ import annotations

import ctypes
import logging
from typing import Any

import numpy as np
from fmpy.sundials import CVodeSolver
from fmpy.sundials.libraries import sundials_core, sundials_cvode
from fmpy.sundials.sundials_context import SUNContext_PushErrHandler
from fmpy.sundials.sundials_types import SUNContext

from fmuid.errors import FmuError
from fmuid.model.channels import Channels
from fmuid.model.instance import Instance
from fmuid.model.plan import RunPlan

RTOL = 1e-8
"""Relative tolerance of CVode (and the tolerance announced to the FMU)."""
MAX_STEPS = 100_000
"""Most internal CVode steps between two communication points."""

logger = logging.getLogger(__name__)

_clear_handlers = sundials_core.SUNContext_ClearErrHandlers
_clear_handlers.argtypes = [SUNContext]
_no_hnil_warnings = sundials_cvode.CVodeSetMaxHnilWarns
_no_hnil_warnings.argtypes = [ctypes.c_void_p, ctypes.c_int]


class _Model:
    """The callbacks CVode calls; a failed FMI call is kept (ctypes callbacks cannot raise)."""

    def __init__(self, instance: Instance, plan: RunPlan, inputs: Channels) -> None:
        self.instance = instance
        self.error: FmuError | None = None
        self.k = 0
        self.plan = plan
        self.index = inputs.continuous
        self.inputs = inputs.subset(self.index)
        names = (
            "SetTime",
            "GetContinuousStates",
            "SetContinuousStates",
            "GetEventIndicators",
            "GetNominalsOfContinuousStates",
            "GetContinuousStateDerivatives" if instance.v3 else "GetDerivatives",
        )
        self.fn = {name: instance.f[instance.prefix + name] for name in names}
        self.c = instance.component

    def _check(self, name: str, status: int, t: float | None = None) -> None:
        if status > 1 and self.error is None:
            when = f"at t = {t} s" if t is not None else "during integration"
            self.error = self.instance.fail(self.instance.prefix + name, status, when)

    def set_time(self, t: float) -> None:
        self._check("SetTime", self.fn["SetTime"](self.c, t), t)  # fmi2SetTime
        k, index = self.k, self.index
        slope = self.plan.slope[k, index]
        if index and np.any(slope):
            value = self.plan.value[k, index] + slope * (t - self.plan.times[k])
            try:
                self.instance.set(self.inputs, value.tolist(), t)
            except FmuError as exc:
                self.error = self.error or exc

    def get_x(self, x: Any, n: int) -> None:
        status = self.fn["GetContinuousStates"](self.c, x, n)  # fmi2GetContinuousStates
        self._check("GetContinuousStates", status)

    def set_x(self, x: Any, n: int) -> None:
        status = self.fn["SetContinuousStates"](self.c, x, n)  # fmi2SetContinuousStates
        self._check("SetContinuousStates", status)

    def get_dx(self, dx: Any, n: int) -> None:
        name = "GetContinuousStateDerivatives" if self.instance.v3 else "GetDerivatives"
        self._check(name, self.fn[name](self.c, dx, n))  # fmi2GetDerivatives

    def get_z(self, z: Any, n: int) -> None:
        status = self.fn["GetEventIndicators"](self.c, z, n)  # fmi2GetEventIndicators
        self._check("GetEventIndicators", status)

    def get_nominals(self, x: Any, n: int) -> None:
        status = self.fn["GetNominalsOfContinuousStates"](self.c, x, n)
        self._check("GetNominalsOfContinuousStates", status)
        nominal = np.ctypeslib.as_array(x, (n,))
        bad = ~(np.isfinite(nominal) & (nominal > 0))
        if not bad.any():
            return
        states = (ctypes.c_double * n)()
        self.get_x(states, n)
        given = nominal[bad].tolist()
        nominal[bad] = np.maximum(np.abs(np.nan_to_num(np.asarray(states)[bad])), 1.0)
        if "nominals" not in self.instance.said:
            self.instance.said.add("nominals")
            logger.warning(
                "%s: the FMU gives invalid nominals %s for %d of its %d continuous states "
                "(they must be positive); fmuid uses max(|x|, 1) instead, for CVode's absolute "
                "tolerances",
                self.instance.model.model_name,
                given,
                int(bad.sum()),
                n,
            )

    def apply(self, t: float) -> None:
        """Do nothing: inputs are set in :meth:`set_time` (fmpy's solver calls this)."""


def _event(
    instance: Instance, t: float, inputs: Channels | None, value: list[float]
) -> float | None:
    """Event mode at ``t`` (setting new inputs when given); returns the next time event.

    Raises ``_Stop`` when the FMU asks to terminate.
    """
    instance.call("EnterEventMode", when=f"at t = {t} s")
    if inputs is not None:
        instance.set(inputs, value, t)
    terminate, t_next = instance.update_discrete_states(t)
    if terminate:
        raise _Stop(t)
    instance.call("EnterContinuousTimeMode", when=f"at t = {t} s")
    return t_next


class _Stop(Exception):
    def __init__(self, t: float) -> None:
        self.t = t


def run_model_exchange(
    instance: Instance, plan: RunPlan, inputs: Channels, outputs: Channels
) -> tuple[np.ndarray, float | None]:
    """Integrate an FMU that has just left initialization mode over the plan's grid.

    Returns
    -------
    result, stopped
        Outputs of shape ``(rows, outputs)`` (rows after a stop are NaN), and the time the FMU
        asked to stop at, or None when it ran to the end.

    Raises
    ------
    FmuError
        When an FMI call fails or CVode cannot continue (naming the time).

    """
    result = np.full((plan.n_rows, outputs.size), np.nan)
    times = plan.times
    description = instance.model.model_description
    try:
        terminate, t_event = instance.update_discrete_states(times[0])
        if terminate:
            return result, times[0]
        instance.call("EnterContinuousTimeMode", when=f"at t = {times[0]} s")
        model = _Model(instance, plan, inputs)
        solver = _solver(instance, model, description, times)
        completed = bool(description.modelExchange.needsCompletedIntegratorStep)
        for k, t in enumerate(times):
            if k:
                t_event = _integrate(instance, model, solver, times[k - 1], t, t_event, completed)
                model.k = k
                if plan.jump[k]:
                    t_event = _event(instance, t, inputs, plan.value[k].tolist())
                    solver.reset(t)
                elif plan.breakpoint[k]:
                    model.set_time(t)
                    solver.reset(t)
            if plan.rows_at[k]:
                result[plan.rows_at[k]] = instance.read(outputs, t)
    except _Stop as stop:
        last = _last_point(plan.times, stop.t)
        if last >= 0 and plan.rows_at[last] and np.isnan(result[plan.rows_at[last][0]]).all():
            result[plan.rows_at[last]] = instance.read(outputs, stop.t)
        return result, stop.t
    return result, None


def _last_point(times: list[float], t: float) -> int:
    """Index of the last grid time at or before ``t`` (within rounding), -1 if none."""
    return int(np.searchsorted(times, t + 1e-12 * max(1.0, abs(t)), side="right")) - 1


def _integrate(
    instance: Instance,
    model: _Model,
    solver: CVodeSolver,
    t: float,
    t_end: float,
    t_event: float | None,
    completed: bool,
) -> float | None:
    """Integrate from ``t`` to ``t_end`` through events; return the next time event."""
    while t < t_end:
        t_stop = t_event if t_event is not None and t < t_event < t_end else t_end
        try:
            state_event, _, t_reached = solver.step(t, t_stop)
        except Exception as exc:  # fmpy raises RuntimeError, bare Exception or TypeError
            _raise(model)
            raise _cvode_error(instance, solver, f"between t = {t} s and {t_stop} s") from exc
        _raise(model)
        model.set_time(t_reached)
        _raise(model)
        step_event = False
        if completed:
            flag = ctypes.c_bool if instance.v3 else ctypes.c_int
            enter, terminate = flag(), flag()
            instance.call(
                "CompletedIntegratorStep",
                1,
                ctypes.byref(enter),
                ctypes.byref(terminate),
                when=f"at t = {t_reached} s",
            )
            if terminate.value:
                raise _Stop(t_reached)
            step_event = bool(enter.value)
        time_event = t_event is not None and t_reached >= t_event - 1e-12 * max(1.0, abs(t_event))
        if state_event or time_event or step_event:
            t_event = _event(instance, t_reached, None, [])
            solver.reset(t_reached)
        t = t_end if abs(t_reached - t_end) <= 1e-12 * max(1.0, abs(t_end)) else t_reached
    return t_event


def _solver(instance: Instance, model: _Model, description: Any, times: list[float]) -> CVodeSolver:
    """Create the CVode solver at the first grid time, with SUNDIALS' stderr line silenced."""
    try:
        solver = CVodeSolver(
            nx=description.numberOfContinuousStates,
            nz=description.numberOfEventIndicators,
            get_x=model.get_x,
            set_x=model.set_x,
            get_dx=model.get_dx,
            get_z=model.get_z,
            get_nominals=model.get_nominals,
            set_time=model.set_time,
            input=model,
            startTime=times[0],
            maxStep=max(times[-1] - times[0], 1e-9) / 50,
            relativeTolerance=RTOL,
            maxNumSteps=MAX_STEPS,
        )
    except Exception as exc:  # fmpy raises a bare Exception when a CVode set-up call fails
        _raise(model)
        raise FmuError(
            f"FMU {instance.model.model_name}: the model-exchange solver (SUNDIALS CVode) could "
            f"not be set up at t = {times[0]} s for its "
            f"{description.numberOfContinuousStates} states: {exc}",
            function="CVode",
        ) from exc
    _raise(model)
    _clear_handlers(solver.sunctx)
    SUNContext_PushErrHandler(solver.sunctx, solver.ehfun_, None)
    _no_hnil_warnings(solver.cvode_mem, -1)  # no "t + h = t" lines on stderr
    return solver


def _cvode_error(instance: Instance, solver: CVodeSolver, span: str) -> FmuError:
    """One message for a failed CVode step: SUNDIALS' own words and what to try."""
    info = solver.error_info
    said = f"{info[3]} (in {info[1]}, code {info[0]})" if info else "no message from SUNDIALS"
    return FmuError(
        f"FMU {instance.model.model_name}: the model-exchange solver (SUNDIALS CVode, relative "
        f"tolerance {RTOL}) failed {span}: {said}; the model may be stiff or singular there at "
        "these parameters (narrow the bounds), or use its co-simulation interface",
        function="CVode",
    )


def _raise(model: _Model) -> None:
    if model.error is not None:
        raise model.error
