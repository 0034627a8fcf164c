"""Which simulator a thread uses: one per parsed FMU, interface and thread, made on first use.

An FMU whose reset was found unreliable is run by a :class:`~fmuid.model.host.HostedSimulator`
from then on; a caller that holds only a file's path gets the file's parsed model, parsed again
only when the file changes.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

from fmuid.errors import FmuError
from fmuid.model.base import as_model
from fmuid.model.fmu import INTERFACES, FmuModel
from fmuid.model.host import HostedSimulator
from fmuid.model.simulator import Simulator

FILE_MODELS = 16
"""Models kept for callers of :func:`get_simulator` that hold only a path."""

_CACHE: dict[tuple[tuple[str, str, str], int], Simulator | HostedSimulator] = {}
_CACHE_PID = os.getpid()
_UNRELIABLE: set[tuple[str, str, str]] = set()
_BY_FILE: dict[tuple[str, int, int, str | None], FmuModel] = {}


def mark_reset_unreliable(model: FmuModel) -> None:
    """Record that the FMU's reset is unreliable: :func:`get_simulator` hosts it from now on.

    The record holds in this process and in the worker processes it forks later.
    """
    _UNRELIABLE.add(model.key)


def fmu_summary(fmu: FmuModel | str | Path, interface: str | None = None) -> dict[str, str]:
    """Say how fmuid runs the FMU: FMI version, interface, input handling, reset."""
    simulator = get_simulator(fmu, interface)
    return {
        "fmi_version": simulator.model.fmi_version,
        "interface": simulator.model.interface,
        "input_handling": simulator.input_handling,
        "instances": simulator.instances,
    }


def _file_model(path: str | Path, interface: str | None) -> FmuModel:
    """Return the model of the file at ``path`` for a caller that holds only the path.

    Parsed again only when the file changes (its modification time or size), so that such a
    caller, e.g. a script simulating in a loop, does not parse the FMU on every run.
    """
    try:
        st = Path(path).stat()
    except OSError as exc:
        raise FmuError(f"FMU {path} does not exist") from exc
    key = (
        str(Path(path).resolve()),
        st.st_mtime_ns,
        st.st_size,
        INTERFACES.get(interface, interface),
    )
    model = _BY_FILE.get(key)
    if model is None:
        model = FmuModel(path, interface)
        if len(_BY_FILE) >= FILE_MODELS:
            _BY_FILE.pop(next(iter(_BY_FILE)))
        _BY_FILE[key] = model
    return model


def get_simulator(
    fmu: FmuModel | str | Path, interface: str | None = None
) -> Simulator | HostedSimulator:
    """Return this thread's simulator of the FMU, creating it on first use.

    FMU instances are not thread-safe, so each thread of a process (e.g. a dask worker with
    several threads) gets its own. The cache key is the model's :attr:`~FmuModel.key` (its
    checksum, file and interface) and the thread, so a rebuilt FMU gets a fresh simulator (the
    old one is closed). A forked child starts with an empty cache. An FMU whose reset was found
    unreliable (by the simulator's first run or by :func:`mark_reset_unreliable`) gets a
    :class:`~fmuid.model.host.HostedSimulator`: a fresh instance per run, in a process replaced
    every ``FMUID_RECYCLE_RUNS`` runs.

    ``fmu`` and ``interface`` are as for :class:`SimulatorBase`; the engine hands on the parsed
    model (a file given by path is parsed again only when it changes).
    """
    global _CACHE_PID
    if _CACHE_PID != os.getpid():
        _CACHE.clear()
        _CACHE_PID = os.getpid()
    model = as_model(fmu, interface) if isinstance(fmu, FmuModel) else _file_model(fmu, interface)
    thread = threading.get_ident()
    key = (model.key, thread)
    simulator = _CACHE.get(key)
    if isinstance(simulator, Simulator) and (
        simulator.reset_reliable is False or model.key in _UNRELIABLE
    ):
        mark_reset_unreliable(model)
        _CACHE.pop(key).close()
        simulator = None
    if simulator is None:
        _, path, wanted = model.key
        for old in [k for k in _CACHE if k[0][1:] == (path, wanted) and k[1] == thread]:
            _CACHE.pop(old).close()
        hosted = model.key in _UNRELIABLE
        simulator = (HostedSimulator if hosted else Simulator)(model)
        _CACHE[key] = simulator
    return simulator
