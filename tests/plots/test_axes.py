"""Every plot function draws into the caller's axes (ax=) and names the count it needs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.demo.compilation import ci_compilation_figure, ci_entries_from_profile
from fmuid.discrepancy.residual_tests import Series, Window
from fmuid.discrepancy.result import Diagnosis
from fmuid.discrepancy.series import DiagnosisSeries
from fmuid.estimation.series import ResidualSeries
from fmuid.experiment_design.discriminate import Discrimination
from fmuid.experiment_design.signals import Trial
from fmuid.plots import (
    diagnosis_fit_figure,
    diagnosis_residual_figure,
    diagnosis_spectrum_figure,
    discrimination_figure,
    fit_figure,
    parameter_paths_figure,
    profile_figure,
    trajectory_band_figure,
)
from fmuid.profiling.band import OutputBand, PathBand, TrajectoryBand
from fmuid.profiling.result import ProfileResult
from fmuid.stages import make_problem

T = np.linspace(0.0, 4.0, 41)


def _gids(ax) -> list[str]:
    return [line.get_gid() for line in ax.lines if line.get_gid()]


def _residual_series() -> list[ResidualSeries]:
    rng = np.random.default_rng(3)
    return [
        ResidualSeries(
            exp,
            "x",
            T,
            np.sin(T) + 0.1 * rng.standard_normal(T.size),
            np.sin(T),
            rng.standard_normal(T.size),
            unit="m",
        )
        for exp in ("step", "ramp")
    ]


def _band() -> TrajectoryBand:
    out = OutputBand("step", "x", "m", T, (np.sin(T), np.cos(T)), np.sin(T), T[::4], np.sin(T[::4]))
    path = {"tractor CG": (T, 0.1 * T)}
    return TrajectoryBand(0.68, 2, (out, out), (PathBand("step", (path, path), path),))


def test_fit_figure_into_given_axes_in_row_order():
    fig = Figure()
    grid = fig.subplots(2, 4)
    assert fit_figure(_residual_series(), ax=grid) is fig
    time_hist, residuals, qq, hist = grid[1]
    assert _gids(time_hist) == ["data", "model"]
    assert time_hist.get_title() == "ramp: x" and time_hist.get_ylabel() == "x [m]"
    assert _gids(residuals) == ["residuals"]
    assert _gids(qq) == ["qq", "qq_line"]
    assert len(hist.patches) > 0
    assert fig.get_suptitle() == ""  # the caller's figure keeps its own title
    with pytest.raises(ValueError, match=r"exactly 8 Axes .*fit_figure.*got 4"):
        fit_figure(_residual_series(), ax=Figure().subplots(1, 4))


def test_trajectory_band_into_subfigure_axes():
    fig = Figure()
    left, right = fig.subfigures(1, 2)
    axes = [*left.subplots(2, 1), right.subplots()]
    assert trajectory_band_figure(_band(), ax=axes) is fig
    assert _gids(axes[0]).count("band") == 2 and "data" in _gids(axes[0])
    assert axes[1].get_ylabel() == "x [m]"
    assert _gids(axes[2]).count("band") == 2 and axes[2].get_xlabel() == "x [m]"
    with pytest.raises(ValueError, match=r"exactly 3 Axes .*2 outputs \+ 1 path.*got 2"):
        trajectory_band_figure(_band(), ax=axes[:2])


def test_compilation_and_profiles_into_given_axes(profile_result: ProfileResult):
    fig = Figure()
    ax_m, ax_k, ax_paths = fig.subplots(1, 3)
    entries = ci_entries_from_profile(profile_result, "SNR 25", true_values={"k": 10.0})
    assert ci_compilation_figure(entries, ax=[ax_m, ax_k], title="CIs") is fig
    assert fig.get_suptitle() == "CIs"
    assert ax_m.get_title() == "m" and _gids(ax_k) == ["ci_bar", "estimate", "true_value"]
    with pytest.raises(ValueError, match=r"exactly 2 Axes .*m, k.*got 3"):
        ci_compilation_figure(entries, ax=[ax_m, ax_k, ax_paths])

    fig2 = Figure()
    pair = fig2.subplots(1, 2)
    assert profile_figure(profile_result, ax=pair) is fig2
    assert [a.get_xlabel() for a in pair] == ["log10(m)", "log10(k)"]
    assert all("profile" in _gids(a) for a in pair)
    with pytest.raises(ValueError, match=r"exactly 2 Axes .*profile_figure.*got 1"):
        profile_figure(profile_result, ax=ax_paths)
    with pytest.raises(ValueError, match=r"exactly 1 Axes .*parameter_paths_figure.*got 2"):
        parameter_paths_figure(profile_result, "m", ax=pair)
    with pytest.raises(TypeError, match="matplotlib Axes.*got Figure"):
        profile_figure(profile_result, "m", ax=fig2)


def test_discrimination_into_given_axes():
    trial = Trial("step", {"time": 1.0, "amplitude": 1.0}, 4.0, 10.0, ("x", "v"))
    preds = {h: {"x": np.sin(T) * s, "v": np.cos(T) * s} for h, s in (("lag", 1.0), ("delay", 0.9))}
    found = Discrimination(
        trial, ("lag", "delay"), {"B": 30.0, "A": 25.0}, T, preds, "f", 12, sigma={"x": 0.1}
    )
    fig = Figure()
    axes = fig.subplots(3, 1)
    assert discrimination_figure(found, ax=axes) is fig
    assert _gids(axes[0]) == ["input"] and axes[0].get_ylabel() == "f"
    assert _gids(axes[2]) == ["prediction_lag", "prediction_delay"]
    assert [c.get_gid() for c in axes[1].collections] == ["noise_band"]  # x has a sigma
    assert not axes[2].collections
    with pytest.raises(ValueError, match=r"exactly 3 Axes .*the input and 2 outputs.*got 2"):
        discrimination_figure(found, ax=axes[1:])


@pytest.fixture(scope="module")
def diagnosis_inputs(msd_fmu: Path) -> tuple[Diagnosis, DiagnosisSeries]:
    spec = spec_from_json(
        '{"parameters": {"k": {"start": 4, "lower": 0.1, "upper": 10}}, "inputs": ["f"],'
        ' "outputs": {"x": {"sigma": 0.1}, "v": {"sigma": 0.1}}}'
    )
    experiments = [
        experiment_from_arrays(name, T, {"f": np.ones_like(T), "x": np.sin(T), "v": np.cos(T)})
        for name in ("a.csv", "b.csv")
    ]
    problem = make_problem(msd_fmu, experiments, spec)
    outputs = [{"x": np.sin(T), "v": np.cos(T)}] * 2
    rng = np.random.default_rng(5)
    residuals = [
        Series(e.name, o, T, rng.standard_normal(T.size))
        for e in problem.experiments
        for o in ("x", "v")
    ]
    series = DiagnosisSeries(problem, outputs, outputs, residuals, residuals)
    diagnosis = Diagnosis(
        mismatch=True,
        false_alarm=0.01,
        evidence=(),
        tests_before=(),
        tests_after=(),
        location={
            "frequency_hz": [1.0, 2.0],
            "time_windows": [[1.0, 2.0]],
            "outputs": ["v"],
            "experiments": [problem.experiments[1].name],
        },
        windows=(Window(problem.experiments[0].name, "x", 0.0, 10.0, 3.0),),
        effect="output_lag",
        description="",
        candidates=(),
        added_parameters={},
        chi2_before=1.0,
        chi2_after=1.0,
        n_data=164,
        lrt_p_value=None,
        bic_before=1.0,
        bic_after=1.0,
        parameters_before={"k": 4.0},
        parameters_after={"k": 4.0},
    )
    return diagnosis, series


def test_diagnosis_figures_into_given_axes(diagnosis_inputs):
    diagnosis, series = diagnosis_inputs
    b = series.problem.experiments[1].name
    fig = Figure()
    fit_axes, res_axes, spec_axes = (sub.subplots(2, 2) for sub in fig.subfigures(1, 3))
    assert diagnosis_fit_figure(series, ax=fit_axes) is fig
    # rows are outputs (x, v), columns experiments (a, b)
    assert fit_axes[1, 0].get_title().endswith(": v") and fit_axes[1, 0].get_ylabel() == "v [m/s]"
    assert fit_axes[0, 1].get_title() == f"{b}: x" and len(fit_axes[0, 1].lines) == 3
    assert diagnosis_residual_figure(diagnosis, series, ax=res_axes) is fig
    # the location's window on b/v, as the report's table states it; not the residual windows
    assert len(res_axes[1, 1].patches) == 1 and not res_axes[0, 1].patches
    assert res_axes[1, 1].patches[0].get_x() == 1.0 and not res_axes[0, 0].patches
    assert diagnosis_spectrum_figure(diagnosis, series, ax=spec_axes.ravel()) is fig
    assert all(_gids(a) == ["spectrum_base"] for a in spec_axes.ravel())
    for draw in (
        lambda ax: diagnosis_fit_figure(series, ax=ax),
        lambda ax: diagnosis_residual_figure(diagnosis, series, ax=ax),
        lambda ax: diagnosis_spectrum_figure(diagnosis, series, ax=ax),
    ):
        with pytest.raises(ValueError, match=r"exactly 4 Axes .*2 outputs x 2 experiments.*got 3"):
            draw(Figure().subplots(1, 3))
