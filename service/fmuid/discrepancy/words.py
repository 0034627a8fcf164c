"""How the effects' sentences name things: units, what a unit measures, declared roles."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

ORDINAL = {2: "square", 3: "cube", 4: "fourth power", 5: "fifth power"}
_QUANTITY = {
    "N": "force",
    "kN": "force",
    "N.m": "torque",
    "N m": "torque",
    "Nm": "torque",
    "m": "displacement",
    "mm": "displacement",
    "rad": "angle",
    "deg": "angle",
    "m/s": "velocity",
    "rad/s": "angular rate",
    "V": "voltage",
    "A": "current",
}


@dataclass(frozen=True)
class Words:
    """Units and declared roles of the FMU's variables, for the effects' sentences."""

    units: Mapping[str, str] = field(default_factory=dict)
    roles: Mapping[str, str] = field(default_factory=dict)

    def unit(self, name: str) -> str:
        """Return the declared unit of a variable ('' when none)."""
        return self.units.get(name, "") or ""

    def per_power(self, target: str, source: str, power: int) -> str:
        """Return the unit of a coefficient taking ``source**power`` into ``target``.

        ``N/m^3`` for a force driven by the cube of a displacement; ``1/m^2`` when the target
        has no unit; the target's unit when the source has none; '' when neither has one.
        """
        top, bottom = self.unit(target), self.unit(source)
        if not bottom:
            return top
        return f"{top or '1'}/{bottom}" + (f"^{power}" if power != 1 else "")

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


def effect_of(name: str) -> str:
    """Return the current name of an effect, mapping the names of earlier versions."""
    return RENAMED.get(name, name)


RENAMED = {
    "sensor_lag": "output_lag",
    "steering_lag": "input_lag",
    "steer_offset": "input_offset",
    "gyro_bias": "output_bias",
}
"""Effect names of earlier versions (result files written by them still load)."""

RENAMED_PARAMETERS = {
    "tau_sensor": "tau_outputs",
    "tau_steer": "tau_delta",
    "offset_steer": "offset_delta",
}
"""Added parameter names of earlier versions (a steer input was named by its role)."""
