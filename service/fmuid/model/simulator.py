"""Repeated simulation of one FMU (FMI 2.0 or 3.0, co-simulation or model exchange).

One instance per simulator, reset between runs; each run is a deterministic function of the
parameters and inputs (no state carried over). The first successful run is repeated after a
reset and compared with the run on the fresh instance: if they differ, the reset is taken as
unreliable and every later run gets a fresh instance. :func:`fmuid.model.registry.get_simulator`
then moves the FMU into a separate process that is replaced after a set number of runs
(:class:`fmuid.model.host.HostedSimulator`), since some exporters fail after about a thousand
instantiations in one process.
"""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
import weakref
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fmuid.errors import FmuError
from fmuid.model.base import INPUT_STEP, SimulatorBase
from fmuid.model.channels import Channels
from fmuid.model.cosim import run_cosimulation
from fmuid.model.exchange import RTOL, run_model_exchange
from fmuid.model.feedback import Feedback, feedback_inputs, fine_times, run_feedback
from fmuid.model.fmu import USABLE, FmuModel, Variable
from fmuid.model.instance import Instance
from fmuid.model.kept import Kept
from fmuid.model.native import run_native_feedback
from fmuid.model.plan import RunPlan, make_plan

logger = logging.getLogger(__name__)

PLAN_CACHE = 32
"""Run plans kept per simulator (one per experiment of a study, typically), within the array
bytes of :data:`~fmuid.model.kept.MAX_BYTES` (:class:`~fmuid.model.kept.Kept`): an input effect
makes new input arrays at every run, and a long record's plans on a fine grid are tens of
megabytes each."""


class Simulator(SimulatorBase):
    """One instance of an FMU, simulated many times with different parameters and inputs.

    Parameters
    ----------
    fmu, interface, input_step
        As for :class:`SimulatorBase`.
    reset_reliable
        False: give every run a fresh instance without checking the reset; None: check it on
        the first run.

    Attributes
    ----------
    model
        The parsed FMU.
    reset_reliable
        None until the first run; then whether a reset run equals a fresh instance's run.
    native
        Whether co-simulation runs use the compiled master loop where it can run
        (:mod:`fmuid.model.native`); False: the Python loop, the reference.

    Raises
    ------
    FmuError
        If the FMU is invalid (see :class:`FmuModel`) or cannot be instantiated.

    """

    def __init__(
        self,
        fmu: FmuModel | str | Path,
        interface: str | None = None,
        input_step: float = INPUT_STEP,
        reset_reliable: bool | None = None,
    ) -> None:
        super().__init__(fmu, interface, input_step)
        self._unzip_dir = tempfile.mkdtemp(prefix="fmuid-fmu-")
        self._cleanup = weakref.finalize(self, _remove_tree, self._unzip_dir, os.getpid())
        self.model.extract(self._unzip_dir)
        self._instance = Instance(self.model, self._unzip_dir)
        self._instance.instantiate()
        self._fresh = True
        self._terminated = False
        self.reset_reliable = reset_reliable
        self.native = True
        self._channels: dict[tuple[str, ...], Channels] = {}
        self._plans: Kept[tuple[Any, ...]] = Kept(PLAN_CACHE)

    @property
    def instances(self) -> str:
        """How runs get their FMU instance (for results and logs)."""
        if self.reset_reliable is False:
            return "a fresh instance per run (its reset is unreliable)"
        return "one instance, reset between runs"

    def _variables(self, names: Sequence[str], role: str) -> list[Variable]:
        table = {
            "parameter": self.model.parameters,
            "input": self.model.inputs,
            "output": self.model.outputs,
        }[role]
        found = []
        for name in names:
            variable = table.get(name)
            if variable is None:
                raise FmuError(
                    f"FMU {self.model.model_name} has no {role} named {name!r}; "
                    f"its {role}s are: {', '.join(table) or 'none'}"
                )
            if variable.kind not in USABLE[role]:
                raise FmuError(
                    f"FMU {self.model.model_name}: {role} {name!r} is of type "
                    f"{variable.type_label}, which fmuid cannot use as {role} "
                    f"(usable: {', '.join(USABLE[role])} scalars)"
                )
            found.append(variable)
        return found

    def _channels_for(self, names: tuple[str, ...], role: str) -> Channels:
        key = (role, *names)
        channels = self._channels.get(key)
        if channels is None:
            channels = Channels(self._variables(names, role), self.model.fmi_version)
            self._channels[key] = channels
        return channels

    def simulate(
        self,
        params: Mapping[str, float | str],
        input_time: np.ndarray,
        input_values: Mapping[str, np.ndarray],
        output_time: np.ndarray,
        outputs: Sequence[str],
        feedback: Feedback | None = None,
        sample_time: np.ndarray | None = None,
    ) -> np.ndarray:
        """Simulate once and return the outputs at the output times.

        Real (float) inputs are linear between their samples; discrete Real, Integer, Boolean and
        Enumeration inputs hold each sample until the next; all are constant before the first
        and after the last sample. The run starts at ``min(input_time[0], output_time[0])``; at
        each output time the inputs of that time are set before the outputs are read (see
        :attr:`input_handling`).

        Parameters
        ----------
        params
            Parameter values by name (a String parameter takes text, a Boolean 0 or 1, an
            Integer or Enumeration a whole number); parameters not given keep their start values.
        input_time
            Non-decreasing sample times of the inputs [s]; a repeated time makes a step.
        input_values
            Samples of each FMU input by name, each of the length of ``input_time``.
        output_time
            Times [s] at which outputs are read; the value at the start time is the one right
            after initialization.
        outputs
            Names of FMU outputs (Real/Float, Integer, Enumeration or Boolean as 0/1).
        feedback
            Terms of the FMU's own outputs added to its inputs at every step of at most
            ``feedback.step`` (:mod:`fmuid.model.feedback`; co-simulation only); an input that
            receives a term but is not in ``input_values`` is driven by the terms alone.
        sample_time
            The times the inputs were sampled at when ``input_time`` resamples them on a finer
            grid (default: ``input_time``). An FMU without input derivatives crosses each
            interval where an input changes in sub-steps of at most ``input_step``, and at most
            :data:`~fmuid.model.base.MAX_SUB_STEPS` per interval of these times, so a finer
            resampling of the same inputs does not multiply the sub-steps.

        Returns
        -------
        numpy.ndarray
            Shape ``(len(output_time), len(outputs))``.

        Raises
        ------
        FmuError
            On an unknown variable name, a variable of a type fmuid cannot use there, a value
            its type cannot hold, an FMI call that returns neither OK nor Warning (naming the
            FMU, the function, the time and the FMU's message), or output times after the time
            at which the FMU asked to stop.
        ValueError
            If the times or input arrays are malformed.

        """
        if feedback is not None:
            return self._simulate_feedback(
                params, input_time, input_values, output_time, outputs, feedback, sample_time
            )
        par = self._channels_for(tuple(params), "parameter")
        inputs = self._channels_for(tuple(input_values), "input")
        out = self._channels_for(tuple(outputs), "output")
        plan, _ = self._plan(input_time, input_values, inputs, output_time, None, sample_time)
        values = list(params.values())
        result, stopped = self._run(values, plan, par, inputs, out)
        if stopped is not None:
            self._terminated = True
        elif self.reset_reliable is None:
            self._check_reset(result, values, plan, par, inputs, out)
        if stopped is not None:
            late = np.asarray(output_time, dtype=float) > stopped
            if late.any():
                raise FmuError(
                    f"FMU {self.model.model_name} stopped the simulation at t = {stopped} s "
                    f"(it asked to terminate), but outputs are wanted up to t = "
                    f"{float(np.max(output_time))} s; give data only up to t = {stopped} s",
                    function=f"{self._instance.prefix}"
                    + ("DoStep" if self.model.is_cosimulation else "UpdateDiscreteStates"),
                    status="terminateSimulation",
                )
        return result

    def _simulate_feedback(
        self,
        params: Mapping[str, float | str],
        input_time: np.ndarray,
        input_values: Mapping[str, np.ndarray],
        output_time: np.ndarray,
        outputs: Sequence[str],
        feedback: Feedback,
        sample_time: np.ndarray | None,
    ) -> np.ndarray:
        """Run with the feedback terms closed around the FMU (see :meth:`simulate`)."""
        if not self.model.is_cosimulation:
            raise FmuError(
                f"FMU {self.model.model_name}: feedback of outputs into inputs needs the "
                "co-simulation interface; this FMU is run by model exchange"
            )
        par = self._channels_for(tuple(params), "parameter")
        names = tuple(dict.fromkeys([*input_values, *feedback.inputs]))
        inputs = self._channels_for(names, "input")
        out = self._channels_for(tuple(outputs), "output")
        sources = self._channels_for(feedback.sources, "output")
        t_out = np.asarray(output_time, dtype=float)
        plan, fine = self._plan(
            input_time, input_values, inputs, output_time, feedback, sample_time
        )
        instance = self._start()
        t0 = float(plan.grid[0])
        instance.setup_experiment(t0, None)
        if par.size:
            instance.set(par, list(params.values()), None)
        instance.enter_initialization(t0, None)
        instance.set(inputs, plan.value[0].tolist(), t0)
        instance.call("ExitInitializationMode", when=f"at t = {t0} s")
        args = (instance, plan, inputs, out, sources, feedback, self.model.can_interpolate_inputs)
        done = run_native_feedback(*args) if self.native else None
        result, stopped = done or run_feedback(*args)
        self._terminated = stopped is not None
        rows = np.searchsorted(fine, t_out)
        if stopped is not None and np.any(np.isnan(result[rows])):
            raise FmuError(
                f"FMU {self.model.model_name} stopped the simulation at t = {stopped} s "
                "with feedback closed around it, before the last output time",
                function=f"{self._instance.prefix}DoStep",
                status="terminateSimulation",
            )
        return result[rows]

    def _plan(
        self,
        input_time: np.ndarray,
        input_values: Mapping[str, np.ndarray],
        inputs: Channels,
        output_time: np.ndarray,
        feedback: Feedback | None = None,
        sample_time: np.ndarray | None = None,
    ) -> tuple[RunPlan, np.ndarray]:
        """Return the run's plan and output grid, reused while the same arrays come back.

        A fit simulates each experiment many times with the same time and input arrays; the
        plan costs about as much as a short run. The arrays are compared by value on every hit.
        With ``feedback`` the output grid is refined to its step (:func:`fine_times`) and its
        undriven inputs are zero.
        """
        sampled = () if sample_time is None else (sample_time,)
        arrays = (input_time, output_time, *sampled, *input_values.values())
        closed = None if feedback is None else (feedback.step, feedback.inputs)
        key = (tuple(input_values), closed, len(sampled), *map(id, arrays))

        def make() -> tuple[Any, ...]:
            values, grid = input_values, np.asarray(output_time, dtype=float)
            if feedback is not None:
                values = feedback_inputs(feedback, input_time, dict(input_values))
                grid = fine_times(grid, feedback.step)
            plan = make_plan(input_time, values, inputs.variables, grid, sample_time)
            return arrays, tuple(np.array(a, dtype=float, copy=True) for a in arrays), plan, grid

        # the arrays are kept alive in the entry, so their ids are theirs; compared by value
        entry = self._plans.get(key, make, lambda e: all(map(np.array_equal, arrays, e[1])))
        return entry[2], entry[3]

    def _check_reset(
        self,
        first: np.ndarray,
        values: list[float | str],
        plan: RunPlan,
        par: Channels,
        inputs: Channels,
        out: Channels,
    ) -> None:
        """Run again after a reset; an error or a different result marks the reset unreliable."""
        try:
            again, _ = self._run(values, plan, par, inputs, out)
            self.reset_reliable = bool(np.array_equal(again, first, equal_nan=True))
        except FmuError:
            self.reset_reliable = False
        if not self.reset_reliable:
            logger.warning(
                "%s: a run after fmi%sReset differs from a fresh instance's; every run now "
                "gets a fresh instance",
                self.model.model_name,
                self.model.fmi_version[0],
            )

    def _start(self) -> Instance:
        """Return an instance in the instantiated state: fresh, reset, or re-created.

        After a run that the FMU terminated, the instance is re-created rather than reset
        (some FMUs keep their terminate flag through a reset).
        """
        instance = self._instance
        if self._fresh and instance.component is not None:
            self._fresh = False
            return instance
        terminated, self._terminated = self._terminated, False
        if self.reset_reliable is not False and not terminated and instance.component is not None:
            if instance.reset():
                return instance
            logger.warning(
                "%s: reset failed; every run now gets a fresh instance", self.model.model_name
            )
            self.reset_reliable = False
        instance.free()
        instance.instantiate()
        return instance

    def _run(
        self,
        values: list[float | str],
        plan: RunPlan,
        par: Channels,
        inputs: Channels,
        out: Channels,
    ) -> tuple[np.ndarray, float | None]:
        instance = self._start()
        t0 = float(plan.grid[0])
        cosim = self.model.is_cosimulation
        instance.setup_experiment(t0, None if cosim else RTOL)
        if par.size:
            instance.set(par, values, None)
        instance.enter_initialization(t0, None if cosim else RTOL)
        if inputs.size:
            instance.set(inputs, plan.value[0].tolist(), t0)
        instance.call("ExitInitializationMode", when=f"at t = {t0} s")
        if not cosim:
            return run_model_exchange(instance, plan, inputs, out)
        step = None if self.model.can_interpolate_inputs else self.input_step
        return run_cosimulation(instance, plan, inputs, out, step, self.native)

    def close(self) -> None:
        """Free the FMU instance, unload its library and delete the extracted files."""
        if self._instance.component is not None:
            self._instance.unload()
        self._cleanup()


def _remove_tree(path: str, owner: int) -> None:
    """Delete the extracted FMU, unless this is a forked copy of its owner (which still uses it)."""
    if os.getpid() == owner:
        shutil.rmtree(path, ignore_errors=True)
