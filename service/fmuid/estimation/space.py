"""The parameter space of a study: names, scales, bounds and the fitted coordinates ``z``.

Every stage maps parameter values to the coordinates it fits, walks and plots in through this
module: ``z = log10(value)`` for a log-scaled parameter and ``z = value`` for a linear one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from fmuid.data import ParameterSpec

BOUND_TOLERANCE = 1e-6
"""A parameter is at a bound within this fraction of its bound span in ``z``."""


def value_to_z(value: float, scale: str) -> float:
    """Return one parameter value in fitted coordinates: ``log10(value)`` when ``scale="log"``."""
    return float(np.log10(value)) if scale == "log" else float(value)


def z_to_value(z: float, scale: str) -> float:
    """Return the parameter value of one fitted coordinate (the inverse of :func:`value_to_z`)."""
    return float(10.0**z) if scale == "log" else float(z)


def value_step(dz: float, value: float, scale: str) -> float:
    """Return the change of a parameter's value for a small step ``dz`` in fitted coordinates.

    ``dz * ln(10) * value`` for a log-scaled parameter at ``value``, ``dz`` for a linear one.
    """
    return dz * np.log(10.0) * value if scale == "log" else dz


@dataclass(frozen=True)
class ParameterSpace:
    """The free parameters of a study and their fitted coordinates.

    Attributes
    ----------
    names
        Free parameter names, in the order of ``z``.
    scales
        ``"log"`` or ``"lin"`` per parameter.
    lower_bounds, upper_bounds
        Bounds per parameter, in parameter units.

    """

    names: tuple[str, ...]
    scales: tuple[str, ...]
    lower_bounds: tuple[float, ...]
    upper_bounds: tuple[float, ...]

    def __post_init__(self) -> None:
        """Check that every parameter has a known scale and ordered bounds."""
        sizes = {len(self.scales), len(self.lower_bounds), len(self.upper_bounds)}
        if sizes != {len(self.names)}:
            raise ValueError(
                f"parameter space: {len(self.names)} names but scales, lower and upper bounds "
                f"of lengths {len(self.scales)}, {len(self.lower_bounds)}, "
                f"{len(self.upper_bounds)}"
            )
        for name, scale, lo, hi in zip(
            self.names, self.scales, self.lower_bounds, self.upper_bounds, strict=True
        ):
            if scale not in ("log", "lin"):
                raise ValueError(f"parameter {name!r}: scale {scale!r} is not 'log' or 'lin'")
            if not lo <= hi:
                raise ValueError(f"parameter {name!r}: lower bound {lo} is above upper bound {hi}")
            if scale == "log" and lo <= 0:
                raise ValueError(f"parameter {name!r}: log scale needs a positive lower bound")

    @classmethod
    def from_specs(cls, parameters: Mapping[str, ParameterSpec]) -> ParameterSpace:
        """Build the space of a spec's free parameters (their resolved scales and bounds)."""
        return cls(
            tuple(parameters),
            tuple(p.resolved_scale for p in parameters.values()),
            tuple(float(p.lower) for p in parameters.values()),
            tuple(float(p.upper) for p in parameters.values()),
        )

    @classmethod
    def from_bounds(
        cls,
        names: Sequence[str],
        scales: Sequence[str],
        lower: Mapping[str, float],
        upper: Mapping[str, float],
    ) -> ParameterSpace:
        """Build a space from name -> bound mappings (as a fit result holds them)."""
        return cls(
            tuple(names),
            tuple(scales),
            tuple(float(lower[n]) for n in names),
            tuple(float(upper[n]) for n in names),
        )

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds in parameter units."""
        return np.array(self.lower_bounds, dtype=float)

    @property
    def upper(self) -> np.ndarray:
        """Upper bounds in parameter units."""
        return np.array(self.upper_bounds, dtype=float)

    @property
    def z_lower(self) -> np.ndarray:
        """Lower bounds in fitted coordinates."""
        return self.to_z(self.lower)

    @property
    def z_upper(self) -> np.ndarray:
        """Upper bounds in fitted coordinates."""
        return self.to_z(self.upper)

    def to_z(self, values: Mapping[str, float] | Sequence[float] | np.ndarray) -> np.ndarray:
        """Map parameter values to fitted coordinates.

        Parameters
        ----------
        values
            A name -> value mapping of every parameter, or values in ``names`` order.

        """
        if isinstance(values, Mapping):
            values = [values[n] for n in self.names]
        array = np.asarray(values, dtype=float)
        if array.shape != (len(self.names),):
            raise ValueError(
                f"parameter space: {len(self.names)} values needed "
                f"({', '.join(self.names)}), got shape {array.shape}"
            )
        return np.array([value_to_z(v, s) for v, s in zip(array, self.scales, strict=True)])

    def from_z(self, z: Sequence[float] | np.ndarray) -> dict[str, float]:
        """Map fitted coordinates back to a name -> value mapping."""
        return {n: z_to_value(zi, s) for n, s, zi in zip(self.names, self.scales, z, strict=True)}

    def at_bound(
        self, z: Sequence[float] | np.ndarray, *, skip: int | None = None
    ) -> tuple[str, ...]:
        """Names of the parameters within :data:`BOUND_TOLERANCE` of their span of a bound.

        Parameters
        ----------
        z
            A point in fitted coordinates.
        skip
            Index of a parameter left out (the profiled one).

        """
        lo, hi = self.z_lower, self.z_upper
        tol = BOUND_TOLERANCE * (hi - lo)
        z = np.asarray(z, dtype=float)
        return tuple(
            n
            for k, n in enumerate(self.names)
            if k != skip and (z[k] <= lo[k] + tol[k] or z[k] >= hi[k] - tol[k])
        )
