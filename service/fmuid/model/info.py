"""What a model offers: its parameters, inputs and outputs (``fmuid info``, ``fmuid.info``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from fmuid.model.builtin import resolve_fmu
from fmuid.model.fmu import Variable, model_of_file
from fmuid.model.smoke import ModelHealth, model_health


@dataclass(frozen=True)
class VariableInfo:
    """One variable as a user needs it to write a spec or a data file.

    Attributes
    ----------
    name, type, unit, description
        As declared in ``modelDescription.xml`` (unit ``""`` when none).
    start
        Start value (``None`` for String/Binary or when none is declared).
    lower, upper
        Declared ``min``/``max``, or ``None``.
    variability
        FMI variability (``fixed``, ``tunable``, ``continuous``, ``discrete``, ...).

    """

    name: str
    type: str
    start: float | None
    unit: str
    description: str
    lower: float | None
    upper: float | None
    variability: str


@dataclass(frozen=True)
class ModelInfo:
    """A model's interface: FMI version and kind, and its variables by causality.

    Attributes
    ----------
    path
        The FMU file.
    model_name, description
        From ``modelDescription.xml``.
    fmi_version
        ``"2.0"`` or ``"3.0"``.
    interface
        The interface fmuid drives: ``CoSimulation`` or ``ModelExchange``.
    interfaces
        Every interface the FMU has.
    parameters, inputs, outputs
        The variables of each causality, in file order.
    health
        What runs at the start values showed (:mod:`fmuid.model.smoke`), or ``None`` when
        not asked for.

    """

    path: Path
    model_name: str
    description: str
    fmi_version: str
    interface: str
    interfaces: tuple[str, ...]
    parameters: tuple[VariableInfo, ...]
    inputs: tuple[VariableInfo, ...]
    outputs: tuple[VariableInfo, ...]
    health: ModelHealth | None = None

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready form (``fmuid info --json``)."""
        out = asdict(self)
        out["path"] = str(self.path)
        return out


def info(model: str | Path, health: bool = True) -> ModelInfo:
    """Describe a model: parameters (start, bounds, unit, description), inputs and outputs.

    Parameters
    ----------
    model
        An FMU file, or the name of a built-in model (e.g. ``"msd"``).
    health
        Also run the FMU at its start values: does it simulate, is a run repeatable, does a
        reset give the same run as a fresh instance.

    Returns
    -------
    ModelInfo
        The FMU's interface as fmuid sees it.

    Raises
    ------
    FmuError
        If the FMU cannot be found or used.

    Examples
    --------
    >>> [p.name for p in fmuid.info("msd").parameters]
    ['m', 'k', 'b']

    """
    path = resolve_fmu(model)
    fmu = model_of_file(path)
    description = fmu.model_description
    declared = {v.name: v for v in description.modelVariables}
    interfaces = fmu.interfaces

    def entries(variables: dict[str, Variable]) -> tuple[VariableInfo, ...]:
        return tuple(_entry(v, declared.get(v.name)) for v in variables.values())

    return ModelInfo(
        path=path,
        model_name=fmu.model_name,
        description=description.description or "",
        fmi_version=fmu.fmi_version,
        interface=fmu.interface,
        interfaces=interfaces,
        parameters=entries(fmu.parameters),
        inputs=entries(fmu.inputs),
        outputs=entries(fmu.outputs),
        health=model_health(fmu, _stop_time(description)) if health else None,
    )


def _stop_time(description: Any) -> float | None:
    """Return the default experiment's stop time, if the FMU declares one."""
    experiment = getattr(description, "defaultExperiment", None)
    try:
        return float(experiment.stopTime) if experiment and experiment.stopTime else None
    except (TypeError, ValueError):
        return None


def _bound(value: object) -> float | None:
    try:
        return None if value is None else float(str(value))
    except ValueError:
        return None


def _entry(v: Variable, declared: Any) -> VariableInfo:
    declared_type = getattr(declared, "declaredType", None)

    def attribute(name: str) -> object:
        own = getattr(declared, name, None)
        return own if own is not None else getattr(declared_type, name, None)

    return VariableInfo(
        name=v.name,
        type=v.type,
        start=v.start,
        unit=v.unit or "",
        description=v.description,
        lower=_bound(attribute("min")),
        upper=_bound(attribute("max")),
        variability=v.variability,
    )
