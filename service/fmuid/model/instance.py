"""One FMI instance (FMI 2.0 or 3.0, co-simulation or model exchange).

Typed get/set, the life-cycle calls the masters need, and :class:`FmuError` naming the FMI
function and status.

fmpy loads the binary and declares the C signatures; the calls themselves go straight to the
library (``fmu._functions``) so that a failed call gives its status instead of an exception.
"""

from __future__ import annotations

import ctypes
import logging
import os
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import fmpy
import numpy as np
from fmpy.fmi2 import (
    FMU2Model,
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2EventInfo,
)
from fmpy.fmi3 import FMU3Model, FMU3Slave

from fmuid.errors import FmuError
from fmuid.model.channels import Channels, to_c
from fmuid.model.fmu import FmuModel

logger = logging.getLogger(__name__)

_SUFFIX = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")


class Instance:
    """One instance of an FMU's binary, driven through raw FMI calls.

    Parameters
    ----------
    model
        The parsed FMU (its ``interface`` says which class of fmpy loads it).
    unzip_dir
        Folder the FMU was extracted to.

    """

    def __init__(self, model: FmuModel, unzip_dir: str) -> None:
        self.model = model
        self.v3 = model.fmi_version == "3.0"
        self.prefix = "fmi3" if self.v3 else "fmi2"
        self.messages: list[str] = []
        self.said: set[str] = set()
        """Topics of warnings already logged for this instance (each is said once)."""
        classes = {
            (False, True): FMU2Slave,
            (False, False): FMU2Model,
            (True, True): FMU3Slave,
            (True, False): FMU3Model,
        }
        cls = classes[(self.v3, model.is_cosimulation)]
        cwd = os.getcwd()
        try:
            self.fmu: Any = cls(
                guid=model.guid,
                unzipDirectory=unzip_dir,
                modelIdentifier=model.model_identifier,
                instanceName=model.model_name,
            )
        except Exception as exc:  # fmpy raises bare Exception when the library does not load
            raise FmuError(
                f"FMU {model.path}: its binary for linux x86-64 does not load as "
                f"{model.kind_label}: {exc}",
                function="dlopen",
            ) from exc
        finally:
            os.chdir(cwd)  # fmpy changes into the binary's folder and may not change back
        self.f: dict[str, Callable[..., Any]] = self.fmu._functions
        self.component: Any = None
        self._v3_step: tuple[Any, Any] = (None, None)
        self.instantiations = 0
        self._set_up = False
        if not self.v3:
            self._callbacks = fmi2CallbackFunctions()
            self._callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
            self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
            self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy.free)

    def _log2(self, env: object, name: bytes, status: int, category: bytes, message: bytes) -> None:
        self._log(status, message)

    def _log3(self, env: object, status: int, category: bytes, message: bytes) -> None:
        self._log(status, message)

    def _log(self, status: int, message: bytes) -> None:
        text = message.decode(errors="replace") if message else ""
        self.messages.append(text)
        del self.messages[:-20]
        logger.debug("%s [%s]: %s", self.model.model_name, self.status_name(status), text)

    def status_name(self, status: int) -> str:
        """``fmi2Discard``, ``fmi3Error``, ... for a status code."""
        return self.prefix + _SUFFIX[status] if 0 <= status < len(_SUFFIX) else str(status)

    def fail(self, function: str, status: int, when: str) -> FmuError:
        """Return the error for a failed FMI call, with the FMU's last message."""
        last = self.messages[-1] if self.messages else "no message from the FMU"
        name = self.status_name(status)
        return FmuError(
            f"FMU {self.model.model_name} ({self.model.path}): {function} returned {name} "
            f"{when}: {last}",
            function=function,
            status=name,
        )

    def call(self, name: str, *args: Any, when: str = "") -> None:
        """Call ``fmi2<name>``/``fmi3<name>`` on this instance; raise unless OK or Warning."""
        function = self.prefix + name
        status = self.f[function](self.component, *args)
        if status > 1:
            raise self.fail(function, status, when)

    def instantiate(self) -> None:
        """Create the instance (``fmi2Instantiate`` / ``fmi3Instantiate...``)."""
        self.messages.clear()
        try:
            if self.v3 and self.model.is_cosimulation:
                self.fmu.instantiate(logMessage=self._log3, eventModeUsed=False)
            elif self.v3:
                self.fmu.instantiate(logMessage=self._log3)
            else:
                self.fmu.instantiate(callbacks=self._callbacks)
        except Exception as exc:  # fmpy raises bare Exception when instantiation returns NULL
            last = self.messages[-1] if self.messages else "no message from the FMU"
            raise FmuError(
                f"FMU {self.model.path}: {self.prefix}Instantiate failed: {last}",
                function=f"{self.prefix}Instantiate",
                status=f"{self.prefix}Error",
            ) from exc
        self.component = self.fmu.component
        self.instantiations += 1
        self._set_up = False

    def reset(self) -> bool:
        """``fmi2Reset``/``fmi3Reset``; False when it fails (the caller instantiates again)."""
        self.messages.clear()
        self._set_up = False
        return bool(self.f[self.prefix + "Reset"](self.component) <= 1)

    def free(self) -> None:
        """Free the instance (the library stays loaded)."""
        if self.component is not None:
            self.f[self.prefix + "FreeInstance"](self.component)
            self.component = None

    def unload(self) -> None:
        """Free the instance and unload the library."""
        self.free()
        self.fmu.freeLibrary()

    def set(self, channels: Channels, values: Sequence[float | str], t: float | None) -> None:
        """Set the channels' variables to ``values`` (converted to their FMI types).

        ``t`` is the time the values belong to (None for parameters), quoted on failure.
        """
        if channels.all_float:
            try:
                channels.buffer[:] = values
            except TypeError:  # a text value: say which variable
                for variable, value in zip(channels.variables, values, strict=True):
                    to_c(variable, value)
                raise
            self._transfer(channels.setters[0], channels.groups[0], t)
            return
        for setter, group in zip(channels.setters, channels.groups, strict=True):
            group[3][:] = [to_c(channels.variables[i], values[i]) for i in group[1]]
            self._transfer(setter, group, t)

    def read(self, channels: Channels, t: float) -> np.ndarray:
        """Return the channels' variables at time ``t`` as numbers (Boolean as 0/1).

        The array is valid until the next read of the same channels.
        """
        if channels.all_float:
            self._transfer(channels.getters[0], channels.groups[0], t, read=True)
            return channels.view
        for getter, group in zip(channels.getters, channels.groups, strict=True):
            self._transfer(getter, group, t, read=True)
            channels.values[group[1]] = group[3][:]
        return channels.values

    def _transfer(
        self,
        function: str,
        group: tuple[str, list[int], Any, Any],
        t: float | None,
        read: bool = False,
    ) -> None:
        if (status := self._status(function, group)) > 1:
            if read:
                when = f"at t = {t} s"
            else:
                when = (
                    "while setting the parameters" if t is None else f"for the inputs at t = {t} s"
                )
            raise self.fail(function, status, when)

    def _status(self, function: str, group: tuple[str, list[int], Any, Any]) -> int:
        index, refs, array = group[1], group[2], group[3]
        n = len(index)
        if self.v3:
            return int(self.f[function](self.component, refs, n, array, n))
        return int(self.f[function](self.component, refs, n, array))

    def bind_set(
        self, channels: Channels
    ) -> tuple[Callable[[Sequence[float]], None], Callable[[], int], str]:
        """Return ``(fill, call, function)`` for setting numeric values in a loop.

        ``fill(values)`` stores the values, ``call()`` passes them to this instance and returns
        the FMI status (the first failed one), ``function`` names the FMI function(s). Bound to
        the current component, without a Python call per value for all-float channels.
        """
        if channels.all_float:
            n = channels.size
            args = (self.component, channels.refs, n, channels.buffer) + ((n,) if self.v3 else ())
            fill = partial(channels.buffer.__setitem__, slice(None))
            return fill, partial(self.f[channels.setters[0]], *args), channels.setters[0]

        def fill_groups(values: Sequence[float]) -> None:
            for group in channels.groups:
                group[3][:] = [to_c(channels.variables[i], values[i]) for i in group[1]]

        def call_groups() -> int:
            statuses = [self._status(f, g) for f, g in zip(channels.setters, channels.groups)]
            return max(statuses, default=0)

        return fill_groups, call_groups, "/".join(channels.setters)

    def bind_get(self, channels: Channels) -> tuple[Callable[[], int], np.ndarray, str]:
        """Return ``(call, values, function)`` for reading in a loop (see :meth:`bind_set`).

        After ``call()`` returned a status below 2, ``values`` holds the numbers.
        """
        if channels.all_float:
            n = channels.size
            args = (self.component, channels.refs, n, channels.buffer) + ((n,) if self.v3 else ())
            return partial(self.f[channels.getters[0]], *args), channels.view, channels.getters[0]

        def call_groups() -> int:
            worst = 0
            for getter, group in zip(channels.getters, channels.groups, strict=True):
                worst = max(worst, self._status(getter, group))
                channels.values[group[1]] = group[3][:]
            return worst

        return call_groups, channels.values, "/".join(channels.getters)

    def bind_derivatives(
        self, channels: Channels
    ) -> tuple[Callable[[Sequence[float]], None], Callable[[], int]] | None:
        """Return ``(fill, call)`` for first-order input slopes (see :meth:`bind_set`).

        ``fill`` takes the slopes of every channel and keeps the continuous inputs'; ``call``
        is ``fmi2SetRealInputDerivatives``. None when no input is continuous.
        """
        index = channels.continuous
        n = len(index)
        if not n:
            return None
        refs = (ctypes.c_uint * n)(*(channels.variables[i].value_reference for i in index))
        order = (ctypes.c_int * n)(*([1] * n))
        der = (ctypes.c_double * n)()
        call = partial(self.f["fmi2SetRealInputDerivatives"], self.component, refs, n, order, der)
        if n == channels.size:
            return partial(der.__setitem__, slice(None)), call

        def fill(slope: Sequence[float]) -> None:
            der[:] = [slope[i] for i in index]

        return fill, call

    def stepper(self) -> Callable[[float, float, int], int]:
        """Return the co-simulation step ``(t, h, 1) -> status`` bound to the current component.

        A status above 1 goes to :meth:`step_outcome`; an FMI 3.0 request to terminate is
        reported as status 2 (as FMI 2.0 reports it, with ``fmi2Discard``).
        """
        component = self.component
        if not self.v3:
            return partial(self.f["fmi2DoStep"], component)
        call3 = self.f["fmi3DoStep"]
        flags = [ctypes.c_bool() for _ in range(3)]
        last = ctypes.c_double()
        refs = (*map(ctypes.byref, flags), ctypes.byref(last))
        self._v3_step = (flags[1], last)

        def step3(t: float, h: float, _: int) -> int:
            status = int(call3(component, t, h, True, *refs))
            return 2 if status <= 1 and flags[1].value else status

        return step3

    def step_outcome(self, status: int, t: float) -> float:
        """Return the time the FMU stopped at after a step with ``status`` > 1, or raise.

        Raises
        ------
        FmuError
            When the step failed without a request to terminate.

        """
        if status == 2 and self.v3:
            terminate, last = self._v3_step
            if terminate.value:
                return float(last.value)
        elif status == 2:
            terminated, when = ctypes.c_int(), ctypes.c_double(t)
            self.f["fmi2GetBooleanStatus"](self.component, 3, ctypes.byref(terminated))
            self.f["fmi2GetRealStatus"](self.component, 2, ctypes.byref(when))
            if terminated.value:
                return float(when.value)
        raise self.fail(f"{self.prefix}DoStep", status, f"in the step from t = {t} s")

    def setup_experiment(self, t0: float, tolerance: float | None) -> None:
        """Call ``fmi2SetupExperiment`` at ``t0`` (FMI 3.0: nothing, see below).

        FMI 3.0 has no such call: the start time and tolerance go with
        ``fmi3EnterInitializationMode``. Called right after instantiation or a reset, before
        the parameters are set, as the standard's examples and FMPy do: some exporters (20-sim)
        re-apply their start values in ``fmi2SetupExperiment``, so that a value set before it
        would be lost.
        """
        if self.v3 or self._set_up:
            return
        tol = (1, tolerance) if tolerance is not None else (0, 0.0)
        self.call("SetupExperiment", *tol, t0, 0, 0.0, when=f"at t = {t0} s")
        self._set_up = True

    def enter_initialization(self, t0: float, tolerance: float | None) -> None:
        """Enter initialization mode at ``t0`` (setting up the experiment first if not done)."""
        when = f"at t = {t0} s"
        if self.v3:
            tol = (1, tolerance) if tolerance is not None else (0, 0.0)
            self.call("EnterInitializationMode", *tol, t0, 0, 0.0, when=when)
            return
        self.setup_experiment(t0, tolerance)
        self.call("EnterInitializationMode", when=when)
        self._set_up = False

    def update_discrete_states(self, t: float) -> tuple[bool, float | None]:
        """Event iteration in event mode: (terminate requested, next time event or None)."""
        when = f"at the event at t = {t} s"
        while True:
            if self.v3:
                flags = [ctypes.c_bool() for _ in range(5)]
                next_time = ctypes.c_double()
                self.call(
                    "UpdateDiscreteStates",
                    *map(ctypes.byref, flags),
                    ctypes.byref(next_time),
                    when=when,
                )
                again, terminate, defined = flags[0].value, flags[1].value, flags[4].value
                t_next = next_time.value
            else:
                info = fmi2EventInfo()
                self.call("NewDiscreteStates", ctypes.byref(info), when=when)
                again, terminate = (
                    bool(info.newDiscreteStatesNeeded),
                    bool(info.terminateSimulation),
                )
                defined, t_next = bool(info.nextEventTimeDefined), info.nextEventTime
            if terminate or not again:
                return terminate, t_next if defined else None
