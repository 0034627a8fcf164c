"""Which simulator a thread uses: one per parsed FMU, interface and thread, made on first use.

An FMU whose reset was found unreliable is run by a :class:`~fmuid.model.host.HostedSimulator`
from then on; a caller that holds only a file's path gets the file's parsed model, parsed again
only when the file changes. What these functions keep lives in this process's
:class:`~fmuid.model.world.FmuRegistry`, opened and closed by the process's entry point.
"""

from __future__ import annotations

from pathlib import Path

from fmuid.model.base import as_model
from fmuid.model.fmu import FmuModel
from fmuid.model.host import HostedSimulator
from fmuid.model.simulator import Simulator
from fmuid.model.world import FmuRegistry, close_at_exit, open_registry, registry

__all__ = [
    "FmuRegistry",
    "close_at_exit",
    "fmu_summary",
    "get_simulator",
    "mark_reset_unreliable",
    "open_registry",
    "registry",
]


def mark_reset_unreliable(model: FmuModel) -> None:
    """Record that the FMU's reset is unreliable: :func:`get_simulator` hosts it from now on.

    The record holds in this process and in the worker processes it forks later.
    """
    registry().mark_reset_unreliable(model.key)


def fmu_summary(fmu: FmuModel | str | Path, interface: str | None = None) -> dict[str, str]:
    """Say how fmuid runs the FMU: FMI version, interface, input handling, reset."""
    simulator = get_simulator(fmu, interface)
    return {
        "fmi_version": simulator.model.fmi_version,
        "interface": simulator.model.interface,
        "input_handling": simulator.input_handling,
        "instances": simulator.instances,
    }


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
    model (a file given by path is parsed again only when it changes: :func:`model_of_file`).
    """
    model = as_model(fmu, interface)
    world = registry()

    def keep(simulator: Simulator | HostedSimulator) -> bool:
        if isinstance(simulator, Simulator) and (
            simulator.reset_reliable is False or world.reset_unreliable(model.key)
        ):
            world.mark_reset_unreliable(model.key)
            return False
        return True

    def make() -> Simulator | HostedSimulator:
        hosted = world.reset_unreliable(model.key)
        return (HostedSimulator if hosted else Simulator)(model)

    return world.simulator(model.key, make, keep)
