"""One scalar variable of an FMU with its FMI names and types, and what fmuid can do with it."""

from __future__ import annotations

from dataclasses import dataclass

import fmpy

FLOAT_TYPES = frozenset({"Real", "Float64", "Float32"})
INTEGER_TYPES = frozenset(
    {
        "Integer",
        "Enumeration",
        "Int8",
        "UInt8",
        "Int16",
        "UInt16",
        "Int32",
        "UInt32",
        "Int64",
        "UInt64",
    }
)
USABLE = {
    "parameter": ("float", "integer", "boolean", "string"),
    "input": ("float", "integer", "boolean"),
    "output": ("float", "integer", "boolean"),
}
"""Variable kinds (:attr:`Variable.kind`) fmuid can set or read in each role."""


@dataclass(frozen=True)
class Variable:
    """One scalar variable of an FMU, with its FMI names.

    Attributes
    ----------
    name
        Variable name in ``modelDescription.xml``.
    value_reference
        FMI value reference.
    causality
        ``parameter``, ``input``, ``output``, ...
    variability
        ``tunable``, ``fixed``, ``continuous``, ``discrete``, ...
    start
        Start value of a numeric variable (Boolean as 0/1), or None.
    unit
        Unit name, or None.
    description
        Free text (may be empty).
    type
        FMI type name: ``Real``, ``Integer``, ``Boolean``, ``String``, ``Enumeration`` (FMI 2.0)
        or ``Float64``, ``Int32``, ``Binary``, ``Clock``, ... (FMI 3.0).
    shape
        Array dimensions (FMI 3.0; -1 where a structural parameter sets the size); empty for a
        scalar.

    """

    name: str
    value_reference: int
    causality: str
    variability: str
    start: float | None
    unit: str | None
    description: str
    type: str = "Real"
    shape: tuple[int, ...] = ()

    @property
    def kind(self) -> str:
        """``float``, ``integer`` (also Enumeration), ``boolean``, ``string`` or ``unusable``."""
        if self.shape:
            return "unusable"
        if self.type in FLOAT_TYPES:
            return "float"
        if self.type in INTEGER_TYPES:
            return "integer"
        return {"Boolean": "boolean", "String": "string"}.get(self.type, "unusable")

    @property
    def is_continuous(self) -> bool:
        """Whether an input is linear between samples (a float that is not ``discrete``)."""
        return self.kind == "float" and self.variability != "discrete"

    @property
    def type_label(self) -> str:
        """The FMI type as a user reads it, e.g. ``Int32`` or ``Float64 array``."""
        return f"{self.type} array" if self.shape else self.type


def _start(value: object, type_name: str) -> float | None:
    if value is None or type_name in ("String", "Binary", "Clock"):
        return None
    text = str(value).strip()
    if type_name == "Boolean":
        return 1.0 if text.lower() in ("true", "1") else 0.0
    try:
        return float(text)
    except ValueError:
        return None


def from_fmpy(v: fmpy.model_description.ModelVariable) -> Variable:
    """Return the :class:`Variable` of one of fmpy's model variables."""
    unit = v.unit if v.unit else (getattr(v.declaredType, "unit", None) if v.declaredType else None)
    shape = tuple(int(d.start) if d.start is not None else -1 for d in v.dimensions)
    return Variable(
        name=v.name,
        value_reference=int(v.valueReference),
        causality=v.causality,
        variability=v.variability or "continuous",
        start=_start(v.start, v.type),
        unit=unit or None,
        description=v.description or "",
        type=v.type,
        shape=shape,
    )
