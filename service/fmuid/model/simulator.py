"""Fast repeated simulation of one FMI 2.0 co-simulation FMU (one instance, reset between runs)."""

from __future__ import annotations

import ctypes
import logging
import os
import shutil
import tempfile
import threading
import weakref
from collections.abc import Mapping, Sequence
from pathlib import Path

import fmpy
import numpy as np
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from fmuid.errors import FmuError
from fmuid.model.fmu import FmuModel

logger = logging.getLogger(__name__)

_STATUS = ("fmi2OK", "fmi2Warning", "fmi2Discard", "fmi2Error", "fmi2Fatal", "fmi2Pending")
_TRUE = 1


class Simulator:
    """One instance of an FMU, simulated many times with different parameters and inputs.

    The FMU is extracted once into a private temporary folder and instantiated once; every
    :meth:`simulate` call starts with ``fmi2Reset``, so unset parameters keep their start values.

    Parameters
    ----------
    path
        The ``.fmu`` file.

    Raises
    ------
    FmuError
        If the FMU is invalid (see :class:`FmuModel`) or cannot be instantiated.

    """

    def __init__(self, path: str | Path) -> None:
        self.model = FmuModel(path)
        self.path = self.model.path
        self._unzip_dir = tempfile.mkdtemp(prefix="fmuid-fmu-")
        self._cleanup = weakref.finalize(self, shutil.rmtree, self._unzip_dir, ignore_errors=True)
        fmpy.extract(str(self.path), unzipdir=self._unzip_dir)
        self._messages: list[str] = []
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy.free)
        cwd = os.getcwd()
        try:
            self._slave = FMU2Slave(
                guid=self.model.guid,
                unzipDirectory=self._unzip_dir,
                modelIdentifier=self.model.model_identifier,
                instanceName=self.model.model_name,
            )
            dll = self._slave.dll
        except Exception as exc:  # fmpy raises bare Exception when the library does not load
            raise FmuError(
                f"FMU {self.path}: its binary for linux64 does not load: {exc}",
                function="dlopen",
            ) from exc
        finally:
            os.chdir(cwd)  # fmpy changes into the binary's folder and may not change back
        self._reset = dll.fmi2Reset
        self._setup = dll.fmi2SetupExperiment
        self._enter = dll.fmi2EnterInitializationMode
        self._exit = dll.fmi2ExitInitializationMode
        self._set_real = dll.fmi2SetReal
        self._get_real = dll.fmi2GetReal
        self._set_der = dll.fmi2SetRealInputDerivatives
        self._do_step = dll.fmi2DoStep
        self._interpolate = self.model.can_interpolate_inputs
        self._vr_cache: dict[tuple[str, ...], ctypes.Array[ctypes.c_uint]] = {}
        self._component: int | None = None
        self._instantiate()

    def _log(
        self, env: object, instance: bytes, status: int, category: bytes, message: bytes
    ) -> None:
        text = message.decode(errors="replace") if message else ""
        self._messages.append(text)
        del self._messages[:-20]
        logger.debug("%s [%s]: %s", self.model.model_name, _STATUS[status], text)

    def _instantiate(self) -> None:
        try:
            self._slave.instantiate(callbacks=self._callbacks)
        except Exception as exc:  # fmpy raises bare Exception when fmi2Instantiate returns NULL
            raise FmuError(
                f"FMU {self.path}: fmi2Instantiate failed: {self._last_message()}",
                function="fmi2Instantiate",
                status="fmi2Error",
            ) from exc
        self._component = self._slave.component

    def _last_message(self) -> str:
        return self._messages[-1] if self._messages else "no message from the FMU"

    def _fail(self, function: str, status: int, when: str) -> FmuError:
        name = _STATUS[status] if 0 <= status < len(_STATUS) else str(status)
        return FmuError(
            f"FMU {self.model.model_name} ({self.path}): {function} returned {name} {when}: "
            f"{self._last_message()}",
            function=function,
            status=name,
        )

    def _value_references(self, names: tuple[str, ...], kind: str) -> ctypes.Array[ctypes.c_uint]:
        key = (kind, *names)
        cached = self._vr_cache.get(key)
        if cached is not None:
            return cached
        table = {
            "parameter": self.model.parameters,
            "input": self.model.inputs,
            "output": self.model.outputs,
        }[kind]
        refs = []
        for name in names:
            variable = table.get(name)
            if variable is None:
                raise FmuError(
                    f"FMU {self.model.model_name} has no {kind} named {name!r}; "
                    f"its {kind}s are: {', '.join(table) or 'none'}"
                )
            refs.append(variable.value_reference)
        array = (ctypes.c_uint * len(refs))(*refs)
        self._vr_cache[key] = array
        return array

    def _start_run(self) -> None:
        self._messages.clear()
        if self._component is None:
            self._instantiate()
        status = self._reset(self._component)
        if status > 1:
            logger.warning("%s: fmi2Reset failed; instantiating again", self.model.model_name)
            self._slave.fmi2FreeInstance(self._component)
            self._component = None
            self._instantiate()

    def simulate(
        self,
        params: Mapping[str, float],
        input_time: np.ndarray,
        input_values: Mapping[str, np.ndarray],
        output_time: np.ndarray,
        outputs: Sequence[str],
    ) -> np.ndarray:
        """Simulate once and return the outputs at the output times.

        Inputs are linear between their samples (and held constant before the first and after
        the last sample). The FMU steps over the sorted union of input sample times and output
        times, starting at ``min(input_time[0], output_time[0])``.

        Parameters
        ----------
        params
            Parameter values by name; parameters not given keep their start values.
        input_time
            Non-decreasing sample times of the inputs [s]; a repeated time makes a step.
        input_values
            Samples of each FMU input by name, each of the length of ``input_time``.
        output_time
            Times [s] at which outputs are read; the value at the start time is the one right
            after initialization.
        outputs
            Names of FMU outputs.

        Returns
        -------
        numpy.ndarray
            Shape ``(len(output_time), len(outputs))``.

        Raises
        ------
        FmuError
            On an unknown variable name or when an FMI call returns a status other than OK or
            Warning (the message names the FMU, the function, the time and the FMU's message).
        ValueError
            If the times or input arrays are malformed.

        """
        t_in = np.asarray(input_time, dtype=float)
        t_out = np.asarray(output_time, dtype=float)
        if t_in.ndim != 1 or t_in.size == 0 or t_out.ndim != 1 or t_out.size == 0:
            raise ValueError("input_time and output_time must be non-empty 1-d arrays")
        if not (np.all(np.isfinite(t_in)) and np.all(np.isfinite(t_out))):
            raise ValueError("input_time and output_time must be finite")
        if np.any(np.diff(t_in) < 0):
            raise ValueError("input_time must be non-decreasing")
        in_names = tuple(input_values)
        in_vr = self._value_references(in_names, "input")
        out_vr = self._value_references(tuple(outputs), "output")
        par_names = tuple(params)
        par_vr = self._value_references(par_names, "parameter")
        samples = np.empty((len(in_names), t_in.size))
        for i, name in enumerate(in_names):
            values = np.asarray(input_values[name], dtype=float)
            if values.shape != t_in.shape:
                raise ValueError(
                    f"input {name!r} has shape {values.shape}, input_time has {t_in.shape}"
                )
            samples[i] = values

        t0 = min(t_in[0], float(np.min(t_out)))
        grid = np.unique(np.concatenate(([t0], t_in[t_in < t_out.max()], t_out)))
        value, slope = _segments(t_in, samples, grid)
        read_index = np.searchsorted(grid, t_out)
        rows_at: list[list[int]] = [[] for _ in grid]
        for row, k in enumerate(read_index.tolist()):
            rows_at[k].append(row)

        n_in, n_out = len(in_names), len(out_vr)
        result = np.empty((t_out.size, n_out))
        out_buf = (ctypes.c_double * n_out)()
        out_view = np.ctypeslib.as_array(out_buf) if n_out else np.empty(0)
        in_buf = (ctypes.c_double * n_in)()
        der_buf = (ctypes.c_double * n_in)()
        order = (ctypes.c_int * n_in)(*([1] * n_in))
        c = self._component_for_run()

        par_buf = (ctypes.c_double * len(par_names))(*(float(params[n]) for n in par_names))
        if par_names and (status := self._set_real(c, par_vr, len(par_names), par_buf)) > 1:
            raise self._fail("fmi2SetReal", status, "while setting the parameters")
        for function, status in (
            ("fmi2SetupExperiment", self._setup(c, 0, 0.0, t0, 0, 0.0)),
            ("fmi2EnterInitializationMode", self._enter(c)),
        ):
            if status > 1:
                raise self._fail(function, status, f"at t = {t0} s")
        if n_in:
            in_buf[:] = value[0].tolist()
            if (status := self._set_real(c, in_vr, n_in, in_buf)) > 1:
                raise self._fail("fmi2SetReal", status, f"for the inputs at t = {t0} s")
        if (status := self._exit(c)) > 1:
            raise self._fail("fmi2ExitInitializationMode", status, f"at t = {t0} s")

        set_real, set_der, do_step, get_real = (
            self._set_real,
            self._set_der,
            self._do_step,
            self._get_real,
        )
        interpolate = self._interpolate and n_in > 0
        times = grid.tolist()
        values = value.tolist()
        slopes = slope.tolist()
        for k, t in enumerate(times):
            rows = rows_at[k]
            if rows:
                if (status := get_real(c, out_vr, n_out, out_buf)) > 1:
                    raise self._fail("fmi2GetReal", status, f"at t = {t} s")
                result[rows] = out_view
            if k + 1 == len(times):
                break
            if n_in:
                in_buf[:] = values[k]
                if (status := set_real(c, in_vr, n_in, in_buf)) > 1:
                    raise self._fail("fmi2SetReal", status, f"for the inputs at t = {t} s")
                if interpolate:
                    der_buf[:] = slopes[k]
                    if (status := set_der(c, in_vr, n_in, order, der_buf)) > 1:
                        raise self._fail("fmi2SetRealInputDerivatives", status, f"at t = {t} s")
            if (status := do_step(c, t, times[k + 1] - t, _TRUE)) > 1:
                raise self._fail("fmi2DoStep", status, f"in the step from t = {t} s")
        return result

    def _component_for_run(self) -> int:
        self._start_run()
        assert self._component is not None
        return self._component

    def close(self) -> None:
        """Free the FMU instance, unload its library and delete the extracted files."""
        if self._component is not None:
            self._slave.fmi2FreeInstance(self._component)
            self._component = None
            self._slave.freeLibrary()
        self._cleanup()


def _segments(
    t_in: np.ndarray, samples: np.ndarray, grid: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Input values at each grid point and slopes over each grid interval.

    Every input breakpoint inside the run is a grid point, so each interval lies in one segment
    of the piecewise-linear input; the value at a grid point is the right limit.

    Returns
    -------
    value, slope
        Arrays of shape ``(len(grid), n_inputs)``; the slope is 0 outside the samples.

    """
    n = t_in.size
    mid = np.append(0.5 * (grid[:-1] + grid[1:]), grid[-1])
    j = np.searchsorted(t_in, mid, side="right") - 1
    inside = (j >= 0) & (j < n - 1)
    jc = np.clip(j, 0, max(n - 2, 0))
    if n > 1:
        dt = t_in[jc + 1] - t_in[jc]
        rate = (samples[:, jc + 1] - samples[:, jc]) / np.where(dt > 0, dt, 1.0)
        slope = np.where(inside, rate, 0.0)
        base = samples[:, jc] + slope * (grid - t_in[jc])
    else:
        slope = np.zeros((samples.shape[0], grid.size))
        base = samples[:, jc]
    value = np.where(j < 0, samples[:, :1], np.where(j >= n - 1, samples[:, -1:], base))
    return value.T.copy(), slope.T.copy()


_CACHE: dict[tuple[str, int, int], Simulator] = {}
_CACHE_PID = os.getpid()
_ALIASES: dict[str, Path] = {}


def register_fmu_copy(path: str | Path, local_copy: Path) -> None:
    """Make :func:`get_simulator` open ``local_copy`` whenever it is asked for ``path``.

    Used on remote workers (dask) that do not see the submitting machine's files: the FMU's
    bytes travel with the work and are written to a local file once.
    """
    _ALIASES[str(path)] = local_copy


def get_simulator(path: str | Path) -> Simulator:
    """Return this thread's :class:`Simulator` for ``path``, creating it on first use.

    FMU instances are not thread-safe, so each thread of a process (e.g. a dask worker with
    several threads) gets its own. The cache key is the resolved path, the file's modification
    time and the thread, so a rebuilt FMU gets a fresh simulator (the old one is closed). A
    forked child starts with an empty cache.

    Parameters
    ----------
    path
        The ``.fmu`` file.

    """
    global _CACHE_PID
    if _CACHE_PID != os.getpid():
        _CACHE.clear()
        _CACHE_PID = os.getpid()
    resolved = _ALIASES.get(str(path), Path(path)).resolve()
    try:
        mtime = resolved.stat().st_mtime_ns
    except OSError as exc:
        raise FmuError(f"FMU {path} does not exist") from exc
    thread = threading.get_ident()
    key = (str(resolved), mtime, thread)
    simulator = _CACHE.get(key)
    if simulator is None:
        for old_key in [k for k in _CACHE if k[0] == key[0] and k[2] == thread]:
            _CACHE.pop(old_key).close()
        simulator = Simulator(resolved)
        _CACHE[key] = simulator
    return simulator
