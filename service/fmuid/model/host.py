"""Simulations of an FMU with an unreliable reset, in a process replaced every so many runs.

When a run after ``fmi2Reset``/``fmi3Reset`` differs from a fresh instance's run, every run needs
a fresh instance, and some exporters fail after about a thousand instantiations in one process
(memory or global state their ``FreeInstance`` does not give back). :class:`HostedSimulator`
therefore runs a :class:`~fmuid.model.simulator.Simulator` with a fresh instance per run in a
child process and replaces that process after ``FMUID_RECYCLE_RUNS`` runs (default
:data:`RECYCLE_RUNS`). The child is forked (cheap: no imports) and loads its own copy of the
FMU's library, extracted to its own folder, so the library's global state starts afresh in
every child even when this process has loaded the FMU before.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import time
import weakref
from collections.abc import Mapping, Sequence
from multiprocessing.connection import Connection
from pathlib import Path

import numpy as np

from fmuid.errors import FmuError, FmuidError
from fmuid.model.base import INPUT_STEP, SimulatorBase
from fmuid.model.feedback import Feedback
from fmuid.model.fmu import FmuModel
from fmuid.model.simulator import Simulator

logger = logging.getLogger(__name__)

RECYCLE_RUNS = 500
"""Default number of runs after which the simulation process is replaced."""
RECYCLE_ENV = "FMUID_RECYCLE_RUNS"
"""Environment variable that sets the number of runs per simulation process."""
STOP_TIMEOUT = 5.0
"""Seconds a retiring simulation process gets to exit before it is killed."""


def recycle_runs() -> int:
    """Return the runs per simulation process: ``FMUID_RECYCLE_RUNS`` or :data:`RECYCLE_RUNS`.

    Raises
    ------
    FmuidError
        If the variable is set to anything but a positive whole number.

    """
    text = os.environ.get(RECYCLE_ENV, "").strip()
    if not text:
        return RECYCLE_RUNS
    try:
        runs = int(text)
    except ValueError:
        runs = 0
    if runs < 1:
        raise FmuidError(f"{RECYCLE_ENV}={text!r}: give a positive whole number of runs")
    return runs


class HostedSimulator(SimulatorBase):
    """A simulator whose runs happen in a child process, with a fresh FMU instance each.

    It has the interface of :class:`~fmuid.model.simulator.Simulator` that the engine uses
    (``simulate``, ``model``, ``input_handling``, ``instances``, ``reset_reliable``, ``close``).

    Parameters
    ----------
    fmu, interface, input_step
        As for :class:`~fmuid.model.simulator.SimulatorBase`.
    runs_per_process
        Runs after which the child process is replaced; default :func:`recycle_runs`.

    Attributes
    ----------
    processes
        Child processes started so far.

    """

    reset_reliable = False

    def __init__(
        self,
        fmu: FmuModel | str | Path,
        interface: str | None = None,
        input_step: float = INPUT_STEP,
        runs_per_process: int | None = None,
    ) -> None:
        super().__init__(fmu, interface, input_step)
        self.runs_per_process = runs_per_process or recycle_runs()
        self.processes = 0
        self._runs = 0
        self._child: _Child | None = None

    @property
    def instances(self) -> str:
        """How runs get their FMU instance (for results and logs)."""
        return (
            "a fresh instance per run (its reset is unreliable), in a process replaced every "
            f"{self.runs_per_process} runs"
        )

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
        """Simulate once in the child process; as :meth:`Simulator.simulate`."""
        if self._child is None or self._runs >= self.runs_per_process:
            self._replace_child()
        assert self._child is not None
        self._runs += 1
        request = (
            dict(params),
            input_time,
            dict(input_values),
            output_time,
            list(outputs),
            feedback,
            sample_time,
        )
        try:
            self._child.conn.send(request)
            kind, *answer = self._child.conn.recv()
        except (EOFError, OSError) as exc:
            code = self._child.stop()
            self._child = None
            how = f"signal {signal.Signals(-code).name}" if code and code < 0 else f"exit {code}"
            raise FmuError(
                f"FMU {self.model.model_name}: the simulation process died during a run "
                f"({how}); its FMU instance crashed or exited",
                function="simulate",
            ) from exc
        if kind == "ok":
            result: np.ndarray = answer[0]
            return result
        if kind == "fmu":
            raise FmuError(answer[0], function=answer[1], status=answer[2])
        raise ValueError(answer[0])

    def _replace_child(self) -> None:
        if self._child is not None:
            self._child.stop()
        self._child = _Child(self.model, self.input_step)
        self.processes += 1
        self._runs = 0
        logger.debug("%s: simulation process %d started", self.model.model_name, self.processes)

    def close(self) -> None:
        """Stop the child process."""
        if self._child is not None:
            self._child.stop()
            self._child = None


class _Child:
    """One simulation process (``os.fork``) and the parent's end of its pipe.

    A plain fork rather than ``multiprocessing.Process``: a dask worker is a daemonic process,
    which multiprocessing does not let start children.
    """

    def __init__(self, model: FmuModel, input_step: float) -> None:
        self.conn, child_conn = multiprocessing.Pipe()
        self.pid = os.fork()
        if self.pid == 0:  # the child: serve, never return into the caller's code
            code = 1
            try:
                for other in list(_LIVE):  # other simulation processes' pipes are not ours
                    other.conn.close()
                self.conn.close()
                _serve(child_conn, model, input_step)
                code = 0
            except BaseException:
                logger.exception("simulation process for %s failed", model.path)
            finally:
                os._exit(code)
        child_conn.close()
        self._owner = os.getpid()
        self._finalizer = weakref.finalize(self, _stop, self.conn, self.pid, self._owner)
        _LIVE.add(self)

    def stop(self) -> int | None:
        """Ask the process to exit, kill it if it does not, and return its exit code."""
        self._finalizer.detach()
        _LIVE.discard(self)
        return _stop(self.conn, self.pid, self._owner)


_LIVE: weakref.WeakSet[_Child] = weakref.WeakSet()


def _stop(conn: Connection, pid: int, owner: int) -> int | None:
    """Stop the simulation process ``pid``; its exit code (negative: the signal), or None."""
    if os.getpid() != owner:  # a forked copy: the process belongs to the parent
        return None
    try:
        conn.send(None)
    except (OSError, ValueError):
        pass
    conn.close()
    deadline = time.monotonic() + STOP_TIMEOUT
    try:
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                return os.waitstatus_to_exitcode(status)
            if time.monotonic() > deadline:
                os.kill(pid, signal.SIGKILL)
                return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
            time.sleep(0.002)
    except ChildProcessError:  # reaped elsewhere
        return None


def _serve(conn: Connection, model: FmuModel, input_step: float) -> None:
    """Child process: answer simulation requests until ``None`` or the parent's end closes.

    The child is forked: it has the parent's parsed model and does not parse the FMU again.
    """
    simulator: Simulator | None = None
    failure: tuple[str | None, ...] | None = None
    try:
        simulator = Simulator(model, input_step=input_step, reset_reliable=False)
    except FmuError as exc:
        failure = ("fmu", str(exc), exc.function, exc.status)
    while True:
        try:
            request = conn.recv()
        except (EOFError, OSError):
            break
        if request is None:
            break
        if simulator is None:
            conn.send(failure)
            continue
        try:
            conn.send(("ok", simulator.simulate(*request)))
        except FmuError as exc:
            conn.send(("fmu", str(exc), exc.function, exc.status))
        except (FmuidError, ValueError) as exc:
            conn.send(("value", str(exc)))
    if simulator is not None:
        simulator.close()
    conn.close()
