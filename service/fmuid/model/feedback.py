"""Closed-loop co-simulation: a static function of the FMU's own outputs added to its inputs.

A black box's left-out internal force (a hardening spring, Coulomb friction, a gap) can be
modelled from outside when the FMU has an input at the place the force acts: at every
communication point the master reads the FMU's outputs, evaluates the feedback terms and adds
them to the measured inputs before the next step. The coupling is explicit (the outputs of the
step's start time): its error shrinks with the step, which :class:`Feedback` bounds; callers
check it by halving the step (``fmuid.discrepancy`` reports that check).

FMUs that take input derivatives get the measured input's slope plus the feedback's slope over
the previous step (a linear extrapolation, second order in the step); the others see the exact
values at the step's start time (for outputs read there) and then hold, over the step, that
line's value at the step's midpoint (also second order: the held value's integral over the
step is the extrapolated line's). Rates and slopes are differences over at least
half the step (:attr:`Feedback.min_gap`): a grid point nearer the last one (an input sample
between fine-grid points) keeps the last ones.

Each term is ``coefficient * shape(x)`` with ``x`` an output, or the finite-difference rate of
an output over the previous step:

=========  ==============================================  ===========================
kind       shape(x)                                        ``shape`` parameter
=========  ==============================================  ===========================
power      ``x ** k``                                      exponent ``k`` (whole)
tanh       ``tanh(x / width)`` (a smooth sign)             ``width`` (> 0)
dead       ``x - clip(x, -band, band)``                    ``band`` (>= 0)
=========  ==============================================  ===========================
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fmuid.errors import FmuError
from fmuid.model.channels import Channels
from fmuid.model.instance import Instance
from fmuid.model.kept import Kept, content_key, read_only
from fmuid.model.plan import RunPlan

KINDS = ("power", "tanh", "dead")


@dataclass(frozen=True)
class FeedbackTerm:
    """One term fed back into an input.

    Attributes
    ----------
    input
        The FMU input that receives the term (in that input's unit).
    source
        The FMU output the term is a function of.
    derivative
        Use the finite-difference rate of ``source`` (unit/s) instead of its value.
    kind
        ``"power"``, ``"tanh"`` or ``"dead"`` (see the module docstring).
    coefficient
        Multiplies the shape.
    shape
        Exponent, width or band of the shape.

    """

    input: str
    source: str
    derivative: bool
    kind: str
    coefficient: float
    shape: float

    def __post_init__(self) -> None:
        """Check the kind and its shape parameter."""
        if self.kind not in KINDS:
            raise ValueError(f"feedback kind {self.kind!r} is not one of {', '.join(KINDS)}")
        if self.kind == "tanh" and not self.shape > 0:
            raise ValueError(f"feedback tanh width must be > 0, got {self.shape}")
        if self.kind == "dead" and not self.shape >= 0:
            raise ValueError(f"feedback dead band must be >= 0, got {self.shape}")

    def value(self, x: float) -> float:
        """Return the term at ``x``."""
        if self.kind == "power":
            return self.coefficient * x ** int(self.shape)
        if self.kind == "tanh":
            return self.coefficient * math.tanh(x / self.shape)
        return self.coefficient * (x - min(max(x, -self.shape), self.shape))


@dataclass(frozen=True)
class Feedback:
    """Terms fed back from outputs into inputs, and the longest co-simulation step [s]."""

    terms: tuple[FeedbackTerm, ...]
    step: float

    @property
    def min_gap(self) -> float:
        """Shortest baseline [s] of a rate or a trend: half the step.

        A grid point closer than this to the last baseline point (an input sample between two
        fine-grid points) keeps the last rate and trend instead of dividing by a tiny interval.
        """
        return 0.5 * self.step

    @property
    def inputs(self) -> tuple[str, ...]:
        """Inputs that receive a term, in first-seen order."""
        return tuple(dict.fromkeys(t.input for t in self.terms))

    @property
    def sources(self) -> tuple[str, ...]:
        """Outputs the terms read, in first-seen order."""
        return tuple(dict.fromkeys(t.source for t in self.terms))


def fine_times(output_time: np.ndarray, step: float) -> np.ndarray:
    """Return output times with points added so that no interval exceeds ``step``.

    The grid is read-only: the last 16 grids are kept by content (:class:`~fmuid.model.kept.Kept`).
    """
    t = np.asarray(output_time, dtype=float)
    return _FINE.get((float(step), *content_key(t)), lambda: read_only(_fine_times(t, step)))


_FINE: Kept[np.ndarray] = Kept(16)
"""Fine grids kept per process (:func:`fine_times`)."""


def _fine_times(t: np.ndarray, step: float) -> np.ndarray:
    gaps = np.diff(t)
    pieces = np.maximum(np.ceil(gaps / step - 1e-9), 1).astype(int)
    if not np.any(pieces > 1):
        return t.copy()
    j = np.arange(pieces.sum()) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    n = np.repeat(pieces, pieces)
    extra = np.repeat(t[:-1], pieces) + np.repeat(gaps, pieces) * j / n
    return np.unique(np.concatenate([t, extra]))


def run_feedback(
    instance: Instance,
    plan: RunPlan,
    inputs: Channels,
    outputs: Channels,
    sources: Channels,
    feedback: Feedback,
    interpolate: bool,
) -> tuple[np.ndarray, float | None]:
    """Step an initialized co-simulation FMU with the feedback terms closed around it.

    Parameters
    ----------
    instance
        An instance that has left initialization mode at ``plan.times[0]``.
    plan
        Grid (no interval longer than ``feedback.step``), measured inputs and output rows.
    inputs
        Every input the plan drives, the feedback's targets among them.
    outputs, sources
        The outputs read into the result, and those the terms read.
    feedback
        The terms.
    interpolate
        Whether the FMU takes input derivatives.

    Returns
    -------
    result, stopped
        As :func:`fmuid.model.cosim.run_cosimulation`.

    """
    result = np.full((plan.n_rows, outputs.size), np.nan)
    names = [v.name for v in inputs.variables]
    src_names = [v.name for v in sources.variables]
    terms = [(names.index(t.input), src_names.index(t.source), t) for t in feedback.terms]
    times, rows_at = plan.times, plan.rows_at
    values, slopes = plan.value, plan.slope
    fill, set_inputs, set_name = instance.bind_set(inputs)
    get_src, src, src_name = instance.bind_get(sources)
    get_out, out, out_name = instance.bind_get(outputs)
    derivatives = instance.bind_derivatives(inputs) if interpolate else None
    step = instance.stepper()
    n_in = inputs.size
    previous, rate = np.zeros(sources.size), np.zeros(sources.size)
    g_prev, trend = np.zeros(n_in), np.zeros(n_in)
    t_prev = times[0]
    last = len(times) - 1
    for k, t in enumerate(times):
        if (status := get_src()) > 1:  # fmi2GetReal & co.
            raise instance.fail(src_name, status, f"at t = {t} s")
        level = np.array(src, dtype=float)
        update = k > 0 and t - t_prev >= feedback.min_gap
        if update:
            rate = (level - previous) / (t - t_prev)
        g = np.zeros(n_in)
        try:
            for i, j, term in terms:
                g[i] += term.value(float(rate[j] if term.derivative else level[j]))
        except OverflowError:
            g[:] = np.inf
        if not np.all(np.isfinite(g)):
            raise diverged(t)
        if update:
            trend = (g - g_prev) / (t - t_prev)
        fill((values[k] + g).tolist())
        if (status := set_inputs()) > 1:  # fmi2SetReal & co.
            raise instance.fail(set_name, status, f"for the inputs at t = {t} s")
        if derivatives is not None:
            derivatives[0]((slopes[k] + trend).tolist())
            if (status := derivatives[1]()) > 1:  # fmi2SetRealInputDerivatives
                raise instance.fail("fmi2SetRealInputDerivatives", status, f"at t = {t} s")
        if rows := rows_at[k]:
            if (status := get_out()) > 1:  # fmi2GetReal & co.
                raise instance.fail(out_name, status, f"at t = {t} s")
            result[rows] = out
        if k == last:
            break
        h = times[k + 1] - t
        if derivatives is None:
            fill((values[k] + g + 0.5 * h * (slopes[k] + trend)).tolist())
            if (status := set_inputs()) > 1:  # fmi2SetReal & co.
                raise instance.fail(set_name, status, f"for the inputs at t = {t + h / 2} s")
        if k == 0 or update:
            previous, g_prev, t_prev = level, g, t
        status = step(t, h, 1)  # fmi2DoStep (fmi3DoStep)
        if status > 1:
            return result, instance.step_outcome(status, t)
    return result, None


def diverged(t: float) -> FmuError:
    """Return the error of a loop the feedback terms drove beyond the float range at ``t`` [s]."""
    return FmuError(
        f"the loop closed around the FMU by the feedback terms diverged at t = {t} s "
        "(outputs or fed-back terms beyond the float range)",
        function="feedback",
    )


def feedback_inputs(
    feedback: Feedback, input_time: np.ndarray, input_values: dict[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """Return the measured inputs with every feedback target present (zero where not driven)."""
    values = dict(input_values)
    for name in feedback.inputs:
        values.setdefault(name, np.zeros(len(input_time)))
    return values
