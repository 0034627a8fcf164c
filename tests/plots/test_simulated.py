import dataclasses
from types import SimpleNamespace

import numpy as np

from fmuid.demo.thesis import DESIGNS, NOMINAL, simulate_dataset, study_spec
from fmuid.estimation.result import Cost, FitResult
from fmuid.estimation.series import residual_series
from fmuid.plots import fit_figure, trajectory_band_figure
from fmuid.profiling.band import trajectory_band
from fmuid.profiling.result import ParameterProfile, ProfilePoint, ProfileResult
from fmuid.stages import make_problem


def _problem(tractor_fmu):
    exp, sigma = simulate_dataset(tractor_fmu, DESIGNS[0], 100.0, np.random.default_rng(1))
    return make_problem(tractor_fmu, [exp], study_spec(sigma))


def test_fit_figure_rows_and_residuals_at_the_truth(tractor_fmu):
    problem = _problem(tractor_fmu)
    series = residual_series(problem, NOMINAL)
    assert [s.output for s in series] == ["gam_t", "gam_i"]
    # at the values that made the data the weighted residuals are the unit-variance noise
    pooled = np.concatenate([s.weighted for s in series])
    assert len(pooled) == 102
    assert 0.7 < pooled.std() < 1.3
    assert {s.unit for s in series} == {"rad/s"}
    fig = fit_figure(series)
    assert fig.axes[0].get_ylabel() == "gam_t [rad/s]"
    assert len(fig.axes) == 2 * 4
    data = [line for line in fig.axes[0].lines if line.get_gid() == "data"]
    assert len(data[0].get_xdata()) == 51


def _profile_result(problem) -> ProfileResult:
    names = problem.names
    fit = FitResult(
        "x",
        "tractor_implement",
        names,
        problem.scales,
        dict(zip(names, problem.lower, strict=True)),
        dict(zip(names, problem.upper, strict=True)),
        dict(NOMINAL),
        100.0,
        102,
        {"gam_t": 1.0},
        {"gam_t": "given"},
        np.eye(len(names)),
    )
    others = {n: v for n, v in NOMINAL.items() if n != "C_atf"}
    points = tuple(
        ProfilePoint(v, chi2, others)
        for v, chi2 in ((2.0e5, 120.0), (2.1e5, 104.0), (2.2e5, 100.0), (2.3e5, 103.0))
    )
    prof = ParameterProfile(
        "C_atf", 2.2e5, 1e4, 7e5, "log", (2.05e5, 2.35e5), (2.1e5, 2.3e5), "identifiable", points
    )
    return ProfileResult(
        fit,
        0.68,
        {"pointwise": 0.99, "simultaneous": 7.04},
        {"C_atf": prof},
        False,
        {},
        Cost(0, 0.0),
    )


def test_trajectory_band_uses_points_inside_the_ci(tractor_fmu):
    problem = _problem(tractor_fmu)
    band = trajectory_band(problem, _profile_result(problem), n=10)
    assert band.n_sets == 3
    fig = trajectory_band_figure(band)
    # two outputs over time plus the CG paths of the one experiment
    assert len([ax for ax in fig.axes if ax.get_visible()]) == 3
    band = [line for line in fig.axes[0].lines if line.get_gid() == "band"]
    assert len(band) == 3  # the point at chi2 120 lies outside 100 + 7.04
    assert len(fig.axes[2].lines) == 2 * 4  # tractor and implement path per parameter set


def test_band_paths_are_the_ones_the_fmu_declares(tractor_fmu, monkeypatch):
    problem = _problem(tractor_fmu)
    band = trajectory_band(problem, _profile_result(problem), n=10)
    (paths,) = band.paths  # one experiment
    assert list(paths.estimate) == ["tractor CG", "implement CG"]  # variables.json "paths"
    assert paths.units == ("m", "m")  # the unit of x_tc and y_tc in the variable table
    # the axis units follow the variable table, whatever it says (a copy: the model may be shared)
    outputs = dict(problem.model.outputs)
    outputs["x_tc"] = dataclasses.replace(outputs["x_tc"], unit="km")
    outputs["y_tc"] = dataclasses.replace(outputs["y_tc"], unit=None)
    model = SimpleNamespace(outputs=outputs, annotation=problem.model.annotation)
    monkeypatch.setattr(problem, "model", model)
    assert trajectory_band(problem, _profile_result(problem), n=1).paths[0].units == ("km", "")
    x, y = paths.estimate["tractor CG"]
    assert x.shape == y.shape == problem.experiments[0].time.shape
    ax = trajectory_band_figure(band).axes[2]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x [m]", "y [m]")
