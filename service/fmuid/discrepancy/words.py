"""How the effects' sentences name things: units, what a unit measures, declared roles."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

ORDINAL = {2: "square", 3: "cube", 4: "fourth power", 5: "fifth power"}
_QUANTITY = {
    "N": "force", "kN": "force", "N.m": "torque", "N m": "torque", "Nm": "torque",
    "m": "displacement", "mm": "displacement", "rad": "angle", "deg": "angle",
    "m/s": "velocity", "rad/s": "angular rate", "V": "voltage", "A": "current",
}  # fmt: skip


@dataclass(frozen=True)
class Words:
    """Units and declared roles of the FMU's variables, for the effects' sentences."""

    units: Mapping[str, str] = field(default_factory=dict)
    roles: Mapping[str, str] = field(default_factory=dict)

    def unit(self, name: str) -> str:
        """Return the declared unit of a variable ('' when none)."""
        return self.units.get(name, "") or ""

    def quantity(self, name: str) -> str | None:
        """Return what a variable's unit measures (``"force"`` for N), if the unit says."""
        return _QUANTITY.get(self.unit(name))

    def variable(self, name: str, side: str) -> str:
        """How a sentence names an input or output: by its role, else by name and unit."""
        role = self.roles.get(name)
        if role:
            return f"the {role} {side} {name}"
        unit = self.unit(name)
        return f"{side} {name}" + (f" [{unit}]" if unit else "")


def num(value: float) -> str:
    """Return a value with three significant digits."""
    return f"{value:.3g}"
