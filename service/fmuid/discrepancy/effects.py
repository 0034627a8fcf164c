"""Effects of left-out physics: each a small class with its parameters, its wrap and its sentence.

An effect wraps the black-box FMU from outside, on one of three sides, or switches on physics
that the FMU declares:

- **input** (the FMU sees a changed input): :class:`InputOffset`, :class:`InputGain`,
  :class:`InputDeadZone`, :class:`InputSaturation`, :class:`InputLag`, :class:`InputDelay`,
  applied in that order;
- **output** (the recording is a changed output): :class:`OutputLag`, :class:`OutputGain`,
  :class:`OutputBias`, :class:`OutputSaturation`, in that order;
- **feedback** (a static function of the FMU's own outputs added to an input, co-simulated step
  by step, :mod:`fmuid.model.feedback`): :class:`FeedbackPolynomial`, :class:`FeedbackFriction`;
- **declared** (:class:`DeclaredPhysics`): FMU parameters that are off by default.

:mod:`.augment` applies them; :mod:`.catalogue` makes them with ranges from the data; the
sentences use the FMU's units and the roles its annotation declares (:class:`Words`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from fmuid.discrepancy.knowledge import AddedParameter
from fmuid.discrepancy.lag import first_order_lag
from fmuid.discrepancy.words import ORDINAL, Words, num
from fmuid.model.feedback import FeedbackTerm


@dataclass(frozen=True)
class Effect:
    """One effect: what it adds, how it wraps the FMU, what it says.

    Attributes
    ----------
    target
        The input or output it acts on ('' for a shared output lag).
    parameters
        The added parameters (names as in the contract's table).
    words
        Units and roles for the sentence.
    affine
        (class) An input map ``a + b u`` of each sample: it commutes with the linear
        interpolation between samples, so it acts on the input's own samples (no fine grid).

    """

    kind: ClassVar[str] = ""
    side: ClassVar[str] = ""
    order: ClassVar[int] = 0
    threshold: ClassVar[bool] = False
    affine: ClassVar[bool] = False
    target: str
    parameters: tuple[AddedParameter, ...]
    words: Words = field(default=Words(), compare=False, repr=False)

    @property
    def effect(self) -> str:
        """The effect's name (the contract's table)."""
        return self.kind

    @property
    def label(self) -> str:
        """Unique label: the effect and its parameter names."""
        return f"{self.effect}({', '.join(p.name for p in self.parameters)})"

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the added parameters."""
        return tuple(p.name for p in self.parameters)

    def value(self, values: Mapping[str, float], k: int = 0) -> float:
        """Value of the ``k``-th added parameter in ``values``."""
        return float(values[self.parameters[k].name])

    def sentence(self, values: Mapping[str, float]) -> str:
        """One sentence on the effect at the fitted ``values``, in physical words."""
        raise NotImplementedError

    def on_input(self, time: np.ndarray, u: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Return the input the FMU sees (input effects)."""
        return u

    def on_output(self, y: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Return the recorded output at the data's rows (output effects)."""
        return y

    def terms(self, p: Mapping[str, float]) -> tuple[FeedbackTerm, ...]:
        """Feedback terms (feedback effects)."""
        return ()


class InputOffset(Effect):
    """The FMU sees the measured input plus a constant offset."""

    kind = "input_offset"
    side, order, affine = "input", 0, True

    def on_input(self, time: np.ndarray, u: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Add the offset."""
        return u + self.value(p)

    def sentence(self, values: Mapping[str, float]) -> str:
        """Offset sentence (a declared role names it: a steer offset)."""
        unit = self.words.unit(self.target)
        size = f"{num(self.value(values))} {unit}".rstrip()
        role = self.words.roles.get(self.target)
        if role:
            return f"a {role} offset of {size}: {self.target} acts as measured + {size}"
        return f"{self.words.variable(self.target, 'input')} carries a constant offset of {size}"


class InputGain(Effect):
    """The FMU sees the measured input times a gain (a calibration error)."""

    kind = "input_gain"
    side, order, affine = "input", 1, True

    def on_input(self, time: np.ndarray, u: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Scale the input."""
        return u * self.value(p)

    def sentence(self, values: Mapping[str, float]) -> str:
        """Gain sentence."""
        g = self.value(values)
        return (
            f"{self.words.variable(self.target, 'input')} acts {g:.4g} times as strongly as "
            f"measured (a calibration or gain error of {100 * (g - 1):+.2g} %)"
        )


class InputDeadZone(Effect):
    """The FMU sees nothing of the input inside +-dead (an actuator's dead zone)."""

    kind = "input_dead_zone"
    side, order, threshold = "input", 2, True

    def on_input(self, time: np.ndarray, u: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Remove the band around zero."""
        d = self.value(p)
        return u - np.clip(u, -d, d)

    def sentence(self, values: Mapping[str, float]) -> str:
        """Dead-zone sentence."""
        unit = self.words.unit(self.target)
        return (
            f"{self.words.variable(self.target, 'input')} has no effect inside a dead zone of "
            f"+-{num(self.value(values))} {unit}".rstrip()
        )


class InputSaturation(Effect):
    """The FMU sees the input clipped at +-limit (an actuator that saturates)."""

    kind = "input_saturation"
    side, order, threshold = "input", 3, True

    def on_input(self, time: np.ndarray, u: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Clip the input."""
        limit = self.value(p)
        return np.clip(u, -limit, limit)

    def sentence(self, values: Mapping[str, float]) -> str:
        """Saturation sentence."""
        unit = self.words.unit(self.target)
        return (
            f"{self.words.variable(self.target, 'input')} saturates at "
            f"+-{num(self.value(values))} {unit}".rstrip()
            + " (the actuator cannot deliver more)"
        )


class InputLag(Effect):
    """The FMU sees the input through a first-order lag (an actuator's time constant)."""

    kind = "input_lag"
    side, order = "input", 4

    def on_input(self, time: np.ndarray, u: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Filter the input (exact for a piecewise-linear input on ``time``)."""
        return first_order_lag(time, u, self.value(p))

    def sentence(self, values: Mapping[str, float]) -> str:
        """Lag sentence."""
        actuator = (
            "actuator"
            if self.target not in self.words.roles
            else (f"{self.words.roles[self.target]}ing actuator")
        )
        return (
            f"{self.words.variable(self.target, 'input')} acts through a first-order "
            f"{actuator} lag of time constant {num(self.value(values))} s"
        )


class InputDelay(Effect):
    """The FMU sees the input ``delay`` seconds late (a dead time); applied by the augmenter."""

    kind = "input_delay"
    side, order = "input", 5

    def sentence(self, values: Mapping[str, float]) -> str:
        """Delay sentence."""
        return (
            f"the model sees {self.words.variable(self.target, 'input')} about "
            f"{num(self.value(values))} s late (dead time)"
        )


class OutputLag(Effect):
    """The recorded output is a first-order lag of the model's (a sensor's filter).

    ``target`` '' lags every fitted output with one time constant (``tau_outputs``).
    """

    kind = "output_lag"
    side, order = "output", 0

    def sentence(self, values: Mapping[str, float]) -> str:
        """Lag sentence."""
        what = (
            "the measured outputs lag"
            if not self.target
            else f"the recorded {self.words.variable(self.target, 'output')} lags"
        )
        return (
            f"{what} the model by a first-order filter of time constant "
            f"{num(self.value(values))} s (a sensor's or a recorder's filter)"
        )


class OutputGain(Effect):
    """The recorded output is a gain times the model's (a sensor's calibration)."""

    kind = "output_gain"
    side, order = "output", 1

    def on_output(self, y: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Scale the output."""
        return y * self.value(p)

    def sentence(self, values: Mapping[str, float]) -> str:
        """Gain sentence."""
        g = self.value(values)
        return (
            f"{self.words.variable(self.target, 'output')} is recorded {g:.4g} times its "
            f"modelled value (a sensor calibration error of {100 * (g - 1):+.2g} %)"
        )


class OutputBias(Effect):
    """The recorded output is the model's plus a constant bias."""

    kind = "output_bias"
    side, order = "output", 2

    def on_output(self, y: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Add the bias."""
        return y + self.value(p)

    def sentence(self, values: Mapping[str, float]) -> str:
        """Bias sentence (a declared role names it: a gyro bias)."""
        unit = self.words.unit(self.target)
        size = f"{num(self.value(values))} {unit}".rstrip()
        role = self.words.roles.get(self.target)
        if role:
            return f"a {role} bias of {size}: {self.target} is recorded as modelled + {size}"
        return (
            f"{self.words.variable(self.target, 'output')} is recorded with a constant bias "
            f"of {size} (a sensor bias)"
        )


@dataclass(frozen=True)
class OutputSaturation(Effect):
    """The recorded output is clipped at a level (a sensor's range, a tank that overflows)."""

    kind = "output_saturation"
    side, order, threshold = "output", 3, True
    upper: bool = True

    def on_output(self, y: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
        """Clip the output at the level."""
        level = self.value(p)
        return np.minimum(y, level) if self.upper else np.maximum(y, level)

    def sentence(self, values: Mapping[str, float]) -> str:
        """Saturation sentence."""
        unit = self.words.unit(self.target)
        where = "above" if self.upper else "below"
        return (
            f"{self.words.variable(self.target, 'output')} cannot go {where} "
            f"{num(self.value(values))} {unit}".rstrip()
            + " (a sensor's range or a physical limit such as an overflow)"
        )


@dataclass(frozen=True)
class FeedbackPolynomial(Effect):
    """``c_k y^k`` of an output ``source`` added to the input ``target``."""

    kind = "feedback_polynomial"
    side = "feedback"
    source: str = ""
    power: int = 3

    def terms(self, p: Mapping[str, float]) -> tuple[FeedbackTerm, ...]:
        """One power term."""
        return (FeedbackTerm(self.target, self.source, False, "power", self.value(p), self.power),)

    def sentence(self, values: Mapping[str, float]) -> str:
        """Physical words: a spring-like force when a force is driven by a displacement."""
        c = self.value(values)
        w = self.words
        power = ORDINAL.get(self.power, f"power {self.power}")
        unit = w.per_power(self.target, self.source, self.power)
        coefficient = f"{self.parameters[0].name} = {num(c)} {unit}".rstrip()
        force, level = w.quantity(self.target), w.quantity(self.source)
        if force in ("force", "torque") and level in ("displacement", "angle"):
            if self.power % 2:
                kind = "a hardening spring" if c < 0 else "a softening spring"
                pull = "restoring" if c < 0 else "destabilising"
                return (
                    f"a {pull} {force} growing with the {power} of the {level} {self.source}: "
                    f"{kind} ({coefficient})"
                )
            return (
                f"a {force} growing with the {power} of the {level} {self.source}, the same on "
                f"both sides (an asymmetric spring, {coefficient})"
            )
        odd = "odd" if self.power % 2 else "even"
        return (
            f"a term growing with the {power} of {w.variable(self.source, 'output')} acts on "
            f"{w.variable(self.target, 'input')} (an {odd} static nonlinearity the model "
            f"leaves out, {coefficient})"
        )


@dataclass(frozen=True)
class FeedbackFriction(Effect):
    """``-F_c tanh(rate / width)`` added to the input ``target``: Coulomb friction.

    ``rate`` is an output that is a rate, or the finite-difference rate of ``source``
    (``derivative``); ``width`` smooths the sign over a small share of the rate's range.
    """

    kind = "feedback_friction"
    side = "feedback"
    source: str = ""
    derivative: bool = False
    width: float = 1.0

    def terms(self, p: Mapping[str, float]) -> tuple[FeedbackTerm, ...]:
        """One smooth-sign term opposing the rate."""
        return (
            FeedbackTerm(
                self.target, self.source, self.derivative, "tanh", -self.value(p), self.width
            ),
        )

    def sentence(self, values: Mapping[str, float]) -> str:
        """Friction words."""
        f = self.value(values)
        w = self.words
        unit = w.unit(self.target)
        rate = f"the rate of {self.source}" if self.derivative else self.source
        force = w.quantity(self.target) or "term"
        if f >= 0:
            return (
                f"Coulomb friction: a {force} of {num(f)} {unit} on "
                f"{w.variable(self.target, 'input')} opposing the motion, switching sign with "
                f"{rate}".replace("  ", " ")
            )
        return (
            f"a {force} of {num(-f)} {unit} on {w.variable(self.target, 'input')} that follows "
            f"the sign of {rate} (it pushes the motion on, unlike friction)".replace("  ", " ")
        )


@dataclass(frozen=True)
class DeclaredPhysics(Effect):
    """Physics the FMU declares (or the spec lists): its parameters are set on the FMU."""

    side = "fmu"
    declared: str = ""
    description: str = ""

    @property
    def effect(self) -> str:
        """The declared name (e.g. ``tire_saturation``)."""
        return self.declared

    def sentence(self, values: Mapping[str, float]) -> str:
        """Return the declaration's own words with the first parameter's value."""
        p = self.parameters[0]
        value = f"{p.name} = {num(values[p.name])} {p.unit}".rstrip()
        return f"{self.description} ({value})"
