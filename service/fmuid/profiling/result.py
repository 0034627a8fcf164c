"""The result of a profile-likelihood study (contract: "Profile result")."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from fmuid.estimation.result import Cost, FitResult
from fmuid.estimation.schema import Written
from fmuid.profiling.schema import ProfileResultOut
from fmuid.provenance import Provenance

if TYPE_CHECKING:
    from fmuid.estimation.problem import Problem

IDENTIFIABLE = "identifiable"
PRACTICALLY_NON_IDENTIFIABLE = "practically_non_identifiable"
STRUCTURALLY_NON_IDENTIFIABLE = "structurally_non_identifiable"


@dataclass(frozen=True)
class ProfilePoint:
    """One point of a profile.

    Attributes
    ----------
    value
        The profiled parameter's value (parameter units).
    chi2
        The re-fitted chi2 there (``nan`` when the simulation or the fit failed).
    params
        The other free parameters after the re-fit.
    at_bound
        Names of the other parameters sitting on a bound there.
    error
        Why the point failed, or ``None``.

    """

    value: float
    chi2: float
    params: dict[str, float]
    at_bound: tuple[str, ...] = ()
    error: str | None = None


@dataclass(frozen=True)
class ProfileQuality:
    """How a profile was checked (contract: ``quality``), summed over its branches.

    Attributes
    ----------
    checks
        Right-valley checks made (re-fits of the other parameters from several starts at a CI
        end or a jump).
    starts
        Starts tried in those checks.
    jumps
        Points where the profile jumped, dropped or bent unexpectedly.
    lower_valleys
        Checks that found a lower chi2 than the walk.
    rewalks
        Stretches re-walked from a lower valley.
    end_refits
        Re-fits spent locating the CI ends by root-finding.
    unsettled
        Why the tool could not settle the profile (empty when it could).
    check_simulations
        Simulations spent on the checks.

    """

    checks: int = 0
    starts: int = 0
    jumps: int = 0
    lower_valleys: int = 0
    rewalks: int = 0
    end_refits: int = 0
    unsettled: tuple[str, ...] = ()
    check_simulations: int = 0

    def __add__(self, other: ProfileQuality) -> ProfileQuality:
        """Combine the records of two branches."""
        return ProfileQuality(
            self.checks + other.checks,
            self.starts + other.starts,
            self.jumps + other.jumps,
            self.lower_valleys + other.lower_valleys,
            self.rewalks + other.rewalks,
            self.end_refits + other.end_refits,
            self.unsettled + other.unsettled,
            self.check_simulations + other.check_simulations,
        )


@dataclass(frozen=True)
class ParameterProfile:
    """Profile, intervals and label of one free parameter.

    ``points`` are sorted by value and include the estimate. A CI end is ``None`` when the
    profile does not cross the threshold inside the bounds.
    """

    name: str
    estimate: float
    lower: float
    upper: float
    scale: str
    ci_simultaneous: tuple[float | None, float | None]
    ci_pointwise: tuple[float | None, float | None]
    status: str
    points: tuple[ProfilePoint, ...]
    limited_by: tuple[str, ...] = ()
    fisher_sd_z: float = float("inf")
    status_reason: str = ""
    quality: ProfileQuality = ProfileQuality()


@dataclass(frozen=True)
class ProfileResult(Written):
    """Profiles of every free parameter around the best fit.

    ``to_dict`` writes the JSON of :class:`~fmuid.profiling.schema.ProfileResultOut`.
    """

    schema = ProfileResultOut

    fit: FitResult
    confidence: float
    thresholds: dict[str, float]
    parameters: dict[str, ParameterProfile]
    better_optimum_found: bool
    structural_check: dict[str, Any]
    cost: Cost
    extra: dict[str, Any] = field(default_factory=dict)
    checks: dict[str, Any] = field(default_factory=dict)
    provenance: Provenance | None = None
    problem: Problem | None = field(default=None, repr=False, compare=False)
    """The problem the stage computed it on (set by ``fmuid.fit``, ``profile``, ``diagnose``;
    not written to the JSON): ``write_report(result, folder)`` needs nothing else."""

    @property
    def chi2(self) -> float:
        """Chi2 at the optimum."""
        return self.fit.chi2

    def to_frame(self) -> Any:
        """Return a pandas table: estimate, both intervals, label and unit per parameter.

        Columns: ``estimate``, ``unit``, ``ci_low``, ``ci_high`` (simultaneous), ``pw_low``,
        ``pw_high`` (pointwise; open ends are NaN), ``status``, ``limited_by``, ``lower``,
        ``upper``, ``scale``.
        """
        from fmuid.frames import nan_if_none, parameter_frame

        return parameter_frame(
            {
                n: {
                    "estimate": p.estimate,
                    "unit": self.fit.units.get(n, ""),
                    "ci_low": nan_if_none(p.ci_simultaneous[0]),
                    "ci_high": nan_if_none(p.ci_simultaneous[1]),
                    "pw_low": nan_if_none(p.ci_pointwise[0]),
                    "pw_high": nan_if_none(p.ci_pointwise[1]),
                    "status": p.status,
                    "limited_by": ", ".join(p.limited_by),
                    "lower": p.lower,
                    "upper": p.upper,
                    "scale": p.scale,
                }
                for n, p in self.parameters.items()
            }
        )

    def path_rows(self) -> list[dict[str, Any]]:
        """Return every profile's path, one row per point (the columns of :meth:`path_frame`)."""
        limit = self.thresholds["simultaneous"]
        return [
            {
                "parameter": name,
                "value": pt.value,
                "chi2": pt.chi2,
                "delta_chi2": pt.chi2 - self.fit.chi2,
                "inside": bool(pt.chi2 - self.fit.chi2 <= limit),
                **{
                    n: pt.params.get(n, pt.value if n == name else float("nan"))
                    for n in self.parameters
                },
                "at_bound": ", ".join(pt.at_bound),
                "error": pt.error or "",
            }
            for name, profile in self.parameters.items()
            for pt in profile.points
        ]

    def path_frame(self) -> Any:
        """Return a pandas table of every profile's path: one row per point, in value order.

        Columns: ``parameter`` (the one profiled), ``value`` (its value there), ``chi2`` (the
        re-fitted chi2; NaN where the point failed), ``delta_chi2`` (above the optimum),
        ``inside`` (``delta_chi2`` within the simultaneous threshold), then the re-fitted value
        of every free parameter (the profiled one holds ``value``), ``at_bound`` (others on a
        bound there) and ``error`` (why a point failed, else empty).
        """
        from fmuid.frames import pandas_module

        return pandas_module().DataFrame(self.path_rows())
