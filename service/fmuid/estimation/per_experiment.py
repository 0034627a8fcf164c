"""Parameters that take one value per experiment (``Spec.per_experiment``): their names.

A real plant's records each start from their own unknown state; an FMU that exposes its initial
states as parameters (``x1_0``, ``h2_init``) lets them be fitted, one value per record. Such a
parameter ``x1_0`` becomes one free parameter per experiment, named ``x1_0@<experiment>`` (the
experiment's file name, e.g. ``x1_0@step.csv``), with the bounds, scale and start of its entry
in the spec's ``parameters``. A predictor hands the FMU, for each experiment, the value of that
experiment under the FMU's own name (:func:`for_experiment`).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from typing import TypeVar

__all__ = ["SEPARATOR", "expand", "for_experiment", "per_experiment_name", "split"]

SEPARATOR = "@"
"""Joins a parameter's name and its experiment's name: ``x1_0@step.csv``."""

V = TypeVar("V")


def per_experiment_name(name: str, experiment: str) -> str:
    """Return the name of parameter ``name``'s value in ``experiment``: ``name@experiment``."""
    return f"{name}{SEPARATOR}{experiment}"


def split(key: str, per_experiment: Collection[str]) -> tuple[str, str] | None:
    """Return ``(name, experiment)`` of a per-experiment parameter's key, else None."""
    for name in per_experiment:
        if key.startswith(name + SEPARATOR):
            return name, key[len(name) + len(SEPARATOR) :]
    return None


def expand(
    parameters: Mapping[str, V], per_experiment: Collection[str], experiments: Iterable[str]
) -> dict[str, V]:
    """Return ``parameters`` with each ``per_experiment`` entry replaced by one per experiment.

    Parameters
    ----------
    parameters
        Free parameters by name (e.g. their :class:`~fmuid.data.ParameterSpec`).
    per_experiment
        The names that take one value per experiment; names already expanded are kept as
        they are, so expanding twice changes nothing.
    experiments
        The experiments' names, in order.

    Returns
    -------
    dict
        The parameters in their order, each per-experiment one replaced by ``name@experiment``
        for every experiment, all with the same value.

    """
    experiments = list(experiments)
    out: dict[str, V] = {}
    for name, value in parameters.items():
        if name in per_experiment:
            out.update({per_experiment_name(name, e): value for e in experiments})
        else:
            out[name] = value
    return out


def for_experiment(
    params: Mapping[str, V], per_experiment: Collection[str], experiment: str
) -> dict[str, V]:
    """Return the parameter values one experiment's simulation takes, under the FMU's names.

    ``name@experiment`` becomes ``name``; the values of the other experiments are left out.
    A per-experiment parameter given without an experiment (``name``) is used when the
    experiment has no value of its own.
    """
    if not per_experiment:
        return dict(params)
    out: dict[str, V] = {}
    for key, value in params.items():
        found = split(key, per_experiment)
        if found is None:
            out.setdefault(key, value)
        elif found[1] == experiment:
            out[found[0]] = value
    return out
