"""FMU health check before profiling: determinism, reset, noise floor, jumps of chi2."""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from fmuid.engine.count import counted, counting
from fmuid.errors import FmuError, FmuidError
from fmuid.estimation.optimize import Mapper, safe_residuals
from fmuid.estimation.predictor import FmuPredictor
from fmuid.estimation.problem import Problem
from fmuid.estimation.schema import Written
from fmuid.model.registry import get_simulator, mark_reset_unreliable
from fmuid.model.simulator import Simulator
from fmuid.model.smoke import held_parameters
from fmuid.profiling.schema import HealthOut
from fmuid.progress import Progress, ProgressCallback

log = logging.getLogger(__name__)

#: Relative step of the noise probe (scipy's default finite-difference step in fitted coordinates).
PROBE_STEP = 1e-6
#: Grid points on each side of the estimate along each parameter, each step raising chi2 by
#: about a quarter when only that parameter moves (so the grid spans a chi2 rise of about 4)...
GRID_SIDE = 4
#: ...but no step longer than this fraction of the parameter's range (weakly sensitive ones).
GRID_SPAN = 2e-3
#: A finite-difference step must make the change of the residuals this many times their noise.
SIGNAL_TO_NOISE = 1e3
#: Largest finite-difference step (relative, fitted coordinates).
MAX_DIFF_STEP = 1e-2
#: Largest finite-difference step of a smooth objective: up to it the raised step's truncation
#: error (about the step, relative) stays below the 1e-3 its noise leaves (``SIGNAL_TO_NOISE``),
#: so trust region and Gauss-Newton converge as at the default step (noise at round-off of an
#: error-controlled solver: chi2 jitters by far less than any threshold).
SMOOTH_STEP = 1e-4
#: Jumps of chi2 (here or along a walked profile) of this fraction of the pointwise threshold
#: limit the intervals: the label says by how much the jumps could move the ends.
NOISY_FRACTION = 0.1


@dataclass(frozen=True)
class Health(Written):
    """What the health check found (reported under ``checks.health`` in the profile result).

    ``to_dict`` writes :class:`~fmuid.profiling.schema.HealthOut`.

    Attributes
    ----------
    deterministic
        Two runs at the estimate gave bit-identical outputs.
    reset_matches_fresh
        A run of the reused (reset) instance equals a run of a fresh instance (``None`` when
        the outputs do not come straight from the FMU).
    noise_floor
        Per parameter: the noise of the weighted residuals under steps of ``PROBE_STEP``
        (fourth differences, Moré and Wild's ECnoise estimate), in units of sigma.
    jumps
        Per parameter: points of a grid along the parameter alone (steps of half its
        conditional standard deviation, at most ``GRID_SPAN`` of its range) where chi2 departs
        from a smooth (quartic) curve.
    chi2_noise
        Per parameter: the largest departure of chi2 on that grid from the smooth curve, in
        chi2 units (the jumps' size; a smooth FMU's is round-off).
    diff_step
        The finite-difference step chosen for the re-fits (relative, fitted coordinates).
    simulations
        Simulations spent on the check.
    no_effect
        Free parameters that move no output at the estimate although the FMU holds the value
        set (a zero column of the sensitivities; the structural check names them).

    """

    deterministic: bool
    reset_matches_fresh: bool | None
    noise_floor: dict[str, float] = field(default_factory=dict)
    jumps: dict[str, int] = field(default_factory=dict)
    chi2_noise: dict[str, float] = field(default_factory=dict)
    diff_step: float = PROBE_STEP
    simulations: int = 0
    no_effect: tuple[str, ...] = ()

    schema = HealthOut

    @classmethod
    def of(cls, written: Mapping[str, Any]) -> Health:
        """Return the health check written as ``written`` (its ``to_dict``)."""
        names = {f.name for f in fields(cls)}
        kept = {k: v for k, v in written.items() if k in names}
        return cls(**{**kept, "no_effect": tuple(kept.get("no_effect", ()))})

    @property
    def smooth(self) -> bool:
        """Whether the objective is deterministic and smooth enough for the default profile.

        No jumps of chi2, and a finite-difference step at most ``SMOOTH_STEP`` (a larger one
        than the default still raises the re-fits' step).

        An unreliable reset does not count: from its detection on every run gets a fresh
        instance, so the objective is as smooth as the FMU.
        """
        return self.deterministic and not any(self.jumps.values()) and self.diff_step <= SMOOTH_STEP

    @property
    def noise_floor_chi2(self) -> float:
        """The largest jump of chi2 along any one parameter (chi2 units)."""
        return max(self.chi2_noise.values(), default=0.0)


class _Meter:
    """Evaluates the residuals, counts the evaluations and says how long the rest will take."""

    def __init__(self, problem: Problem, total: int, progress: ProgressCallback | None) -> None:
        self.problem, self.total, self.progress = problem, total, progress
        self.done = 0
        self.seconds = 0.0

    def __call__(self, z: np.ndarray) -> np.ndarray:
        t0 = time.perf_counter()
        r = safe_residuals(self.problem, z)
        self.seconds += time.perf_counter() - t0
        self.done += 1
        per_run = self.seconds / self.done
        if self.done == 1:
            log.info(
                "health check: %d runs of the %d experiment(s) at %.3g s each, about %.0f s "
                "(shorten it with CheckOptions.health_grid)",
                self.total,
                len(self.problem.experiments),
                per_run,
                per_run * self.total,
            )
        if self.progress is not None:
            left = per_run * max(self.total - self.done, 0)
            self.progress(
                Progress(
                    "health", self.done, self.total, f"{per_run:.3g} s per run, {left:.0f} s left"
                )
            )
        return r

    def ran(self, runs: int, detail: str) -> None:
        """Count ``runs`` made elsewhere (as tasks); report them as one step."""
        self.done += runs
        if self.progress is not None:
            self.progress(Progress("health", self.done, self.total, detail))


def check_health(
    problem: Problem,
    z_hat: np.ndarray,
    jacobian: np.ndarray,
    progress: ProgressCallback | None = None,
    grid_side: int = GRID_SIDE,
    mapper: Mapper | None = None,
) -> Health:
    """Probe the objective around the estimate.

    Parameters
    ----------
    problem
        The estimation problem.
    z_hat
        The estimate in fitted coordinates.
    jacobian
        Weighted residual Jacobian at the estimate (fitted coordinates); its column norms set
        the grid steps.
    progress
        Receives ``Progress("health", done, total, detail)`` after each run of the experiments
        (the detail says the measured cost per run and the time left); the first run's cost
        and the number of runs are also logged.
    grid_side
        Grid points on each side of the estimate along each parameter (``GRID_SIDE``; fewer
        make a shorter check for slow FMUs; below 3 no jumps are looked for).
    mapper
        Runs the probes of each parameter as a task (a profile's engine: ``map``), the same
        runs as here; then one progress event follows them all. The runs at the estimate and
        the check of the reset stay in this process.

    Returns
    -------
    Health
        With ``diff_step`` raised above the noise floor where the residuals are noisy.

    Raises
    ------
    FmuError
        When a free parameter moves no output and the FMU does not hold the value set (it
        ignored it; see :func:`ignored_parameters`).

    """
    with counting() as count:
        health = _check(problem, z_hat, jacobian, progress, grid_side, mapper)
    return replace(health, simulations=count.simulations)


def _check(
    problem: Problem,
    z_hat: np.ndarray,
    jacobian: np.ndarray,
    progress: ProgressCallback | None,
    grid_side: int,
    mapper: Mapper | None,
) -> Health:
    """Run :func:`check_health`'s measurements (its simulations not counted here)."""
    no_effect = ignored_parameters(problem, z_hat, jacobian)
    fresh = _fresh_matches(problem, z_hat)  # first: the rest sees fresh instances if need be
    probes = [_probes(problem, z_hat, jacobian, i, grid_side) for i in range(problem.n_free)]
    residuals = _Meter(problem, 2 + sum(len(p.points) for p in probes), progress)
    r0 = residuals(z_hat)
    deterministic = bool(np.array_equal(r0, residuals(z_hat)))
    if mapper is None:
        rows = [[residuals(z) for z in p.points] for p in probes]
    else:
        rows = mapper(residual_rows, [problem] * len(probes), [p.points for p in probes])
        residuals.ran(sum(len(r) for r in rows), "probes run as tasks")
    noise: dict[str, float] = {}
    jumps: dict[str, int] = {}
    chi2_noise: dict[str, float] = {}
    steps = [PROBE_STEP]
    with np.errstate(over="ignore", invalid="ignore"):  # outputs that overflow at wide bounds
        for i, (name, probe, got) in enumerate(zip(problem.names, probes, rows, strict=True)):
            moved = [r0, *got[:4]]
            fourth = moved[0] - 4 * moved[1] + 6 * moved[2] - 4 * moved[3] + moved[4]
            noise[name] = float(np.sqrt(np.mean(fourth**2) / 70.0))
            slope = np.sqrt(np.mean(((moved[1] - moved[0]) / probe.h) ** 2))
            if noise[name] > 0 and slope > 0:
                steps.append(SIGNAL_TO_NOISE * noise[name] / slope / probe.scale)
            along = iter(got[4:])
            chi2 = np.array(
                [float(r @ r) for r in (r0 if g == z_hat[i] else next(along) for g in probe.grid)]
            )
            jumps[name], chi2_noise[name] = _departures(probe.grid, chi2)
    return Health(
        deterministic=deterministic,
        reset_matches_fresh=fresh,
        noise_floor=noise,
        jumps=jumps,
        chi2_noise=chi2_noise,
        diff_step=float(min(max(steps), MAX_DIFF_STEP)),
        no_effect=no_effect,
    )


@dataclass(frozen=True)
class _Probes:
    """The points of one parameter's probes: four noise steps of ``h``, then its grid."""

    h: float
    scale: float
    grid: np.ndarray
    points: list[np.ndarray]


def _probes(
    problem: Problem, z_hat: np.ndarray, jacobian: np.ndarray, i: int, grid_side: int
) -> _Probes:
    """Return parameter ``i``'s probes: noise steps, its grid (no run at the estimate itself)."""
    lo, hi = problem.z_lower, problem.z_upper
    scale = max(1.0, abs(float(z_hat[i])))
    h = PROBE_STEP * scale * (1.0 if z_hat[i] + 4 * PROBE_STEP * scale <= hi[i] else -1.0)
    norm = float(np.linalg.norm(jacobian[:, i]))
    d = min(0.5 / norm if norm > 0 else np.inf, GRID_SPAN * (hi[i] - lo[i]))
    grid = np.unique(np.clip(z_hat[i] + d * np.arange(-grid_side, grid_side + 1), lo[i], hi[i]))
    points = [_moved(z_hat, i, k * h) for k in range(1, 5)]
    points += [_at(z_hat, i, g) for g in grid if g != z_hat[i]]
    return _Probes(h, scale, grid, points)


def residual_rows(problem: Problem, points: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Return the weighted residuals at each point (a failed run: its penalty); a task's work."""
    return [safe_residuals(problem, z) for z in points]


def ignored_parameters(
    problem: Problem, z_hat: np.ndarray, jacobian: np.ndarray
) -> tuple[str, ...]:
    """Check that every free parameter with a zero sensitivity column is held by the FMU.

    A zero column means the parameter moves no output. When the FMU gives back the value set,
    the model does not use the parameter here (a structural finding); when it gives back
    another value or none, the FMU ignored what fmuid set (as 20-sim's FMUs do with a value set
    before ``fmi2SetupExperiment``), and every answer about that parameter would be wrong.

    Returns
    -------
    tuple of str
        The free parameters that move no output although the FMU holds their values.

    Raises
    ------
    FmuError
        Naming the parameters the FMU ignored, the value set and the value it holds.

    """
    dead = tuple(name for i, name in enumerate(problem.names) if not np.any(jacobian[:, i]))
    predictor = problem.predictor
    if not dead or not isinstance(predictor, FmuPredictor):
        return dead
    values = predictor.fmu_values(problem.from_z(z_hat), problem.experiments[0])
    model = predictor.model
    try:
        held = held_parameters(model, values)
    except FmuError as exc:
        raise FmuError(
            f"FMU {model.model_name}: {', '.join(dead)} move(s) no output, and reading the "
            f"value back failed ({exc}), so the FMU probably ignored what fmuid set",
            function=exc.function,
            status=exc.status,
        ) from exc
    ignored = [
        n
        for n in dead
        if n in held and not np.isclose(held[n], float(values[n]), rtol=1e-9, atol=0.0)
    ]
    if ignored:
        said = ", ".join(f"{n} set to {float(values[n]):.6g} holds {held[n]:.6g}" for n in ignored)
        raise FmuError(
            f"FMU {model.model_name} ignored the parameter(s) {', '.join(ignored)}: they move "
            f"no output, and after initialization the FMU holds another value than fmuid set "
            f"({said}); it may re-apply its start values after they are set, or not read them "
            "from the master at all; fix the FMU's export (or fix these parameters in the spec)",
            function="fmi3SetFloat64" if model.fmi_version == "3.0" else "fmi2SetReal",
        )
    log.warning(
        "%s move(s) no output of FMU %s at the estimate (a zero sensitivity column)",
        ", ".join(dead),
        model.model_name,
    )
    return dead


def _moved(z: np.ndarray, i: int, dz: float) -> np.ndarray:
    out = z.copy()
    out[i] += dz
    return out


def _at(z: np.ndarray, i: int, zi: float) -> np.ndarray:
    out = z.copy()
    out[i] = zi
    return out


def _departures(grid: np.ndarray, chi2: np.ndarray) -> tuple[int, float]:
    """Count the points off a least-squares quartic by 1 % of chi2's range; the largest offset.

    The offset is in chi2 units.
    """
    if grid.size < 7 or not np.all(np.isfinite(chi2)):  # a quartic needs more than five points
        return 0, 0.0
    x = (grid - grid.mean()) / (np.ptp(grid) or 1.0)
    off = np.abs(chi2 - np.polyval(np.polyfit(x, chi2, 4), x))
    spread = max(float(np.ptp(chi2)), 1e-9 * max(1.0, float(np.max(np.abs(chi2)))))
    return int(np.sum(off > 0.01 * spread)), float(np.max(off))


def _fresh_matches(problem: Problem, z_hat: np.ndarray) -> bool | None:
    """Compare the reused instance's outputs with a fresh instance's, experiment by experiment.

    When they differ, the FMU's reset is unreliable: :func:`mark_reset_unreliable` makes every
    later run, here and in the branch workers forked after this check, use a fresh instance in
    a recycled simulation process.
    """
    predictor = problem.predictor
    if not isinstance(predictor, FmuPredictor):
        return None
    if get_simulator(predictor.model).reset_reliable is False:
        return False
    reused = problem.predict(problem.from_z(z_hat))
    try:
        sim = Simulator(predictor.model, reset_reliable=False)
    except FmuidError:
        return False
    try:
        for exp, out in zip(problem.experiments, reused, strict=True):
            t_in, u = predictor.inputs_of(exp)
            values = predictor.fmu_values(problem.from_z(z_hat), exp)
            y = sim.simulate(values, t_in, u, exp.time, problem.outputs)
            counted()
            if not all(
                np.array_equal(y[:, j], out[o], equal_nan=True)
                for j, o in enumerate(problem.outputs)
            ):
                mark_reset_unreliable(predictor.model)
                return False
    except FmuidError:
        return False
    finally:
        sim.close()
    return True
