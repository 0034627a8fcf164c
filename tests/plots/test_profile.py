import math

import numpy as np
from matplotlib.figure import Figure

from fmuid.plots import parameter_paths_figure, profile_figure
from plots.toy import CHI2_OPT, THRESHOLDS


def _lines(ax, gid):
    return [line for line in ax.lines if line.get_gid() == gid]


def test_profile_figure_has_one_panel_per_parameter(profile_result):
    fig = profile_figure(profile_result)
    assert isinstance(fig, Figure)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_xlabel() for ax in axes] == ["log10(m)", "log10(k)"]


def test_threshold_lines_sit_at_optimum_plus_threshold(profile_result):
    ax = profile_figure(profile_result).axes[0]
    for kind in ("pointwise", "simultaneous"):
        (line,) = _lines(ax, f"threshold_{kind}")
        assert np.allclose(line.get_ydata(), CHI2_OPT + THRESHOLDS[kind])
        assert line.get_linestyle() == "--"


def test_profile_quadratic_estimate_bound_and_failed_points(profile_result):
    fig = profile_figure(profile_result)
    for ax, name in zip(fig.axes, ("m", "k"), strict=False):
        prof = profile_result.parameters[name]
        (profile,) = _lines(ax, "profile")
        # 13 points, one failed: 12 drawn, in log10 coordinates
        assert len(profile.get_xdata()) == 12
        assert np.allclose(profile.get_xdata()[0], math.log10(prof.points[0].value))
        (quad,) = _lines(ax, "quadratic")
        # the toy profile is exactly quadratic with the Fisher sd: the two curves agree
        x = np.asarray(quad.get_xdata())
        expected = CHI2_OPT + ((x - math.log10(prof.estimate)) / prof.fisher_sd_z) ** 2
        assert np.allclose(quad.get_ydata(), expected)
        (est,) = _lines(ax, "estimate")
        assert est.get_xdata()[0] == math.log10(prof.estimate)
        assert est.get_ydata()[0] == CHI2_OPT
        (bound,) = _lines(ax, "at_bound")
        assert len(bound.get_xdata()) == 1
        (failed,) = _lines(ax, "failed")
        assert len(failed.get_xdata()) == 1


def test_parameter_paths_draw_each_other_parameter(profile_result):
    fig = parameter_paths_figure(profile_result, "m")
    (ax,) = fig.axes
    (path,) = _lines(ax, "path_k")
    x = np.asarray(path.get_xdata())
    y = np.asarray(path.get_ydata())
    # the toy k moves -0.5 decades per decade of m
    assert np.allclose(np.diff(y) / np.diff(x), -0.5)
    assert [t.get_text() for t in ax.get_legend().get_texts()][0] == "k"


def test_profile_into_a_given_ax_draws_one_parameter_with_its_unit(profile_result):
    import dataclasses

    result = dataclasses.replace(
        profile_result, fit=dataclasses.replace(profile_result.fit, units={"k": "N/m"})
    )
    fig = Figure()
    ax, other = fig.subplots(1, 2)
    assert profile_figure(result, "k", ax=ax) is fig
    assert ax.get_xlabel() == "log10(k [N/m])"
    assert len(_lines(ax, "profile")) == 1
    assert not other.lines
    assert parameter_paths_figure(result, "k", ax=other) is fig
    assert [line.get_gid() for line in other.lines if line.get_gid()] == ["path_m"]


def test_profile_into_an_ax_needs_one_axes_per_parameter(profile_result):
    import pytest

    ax = Figure().subplots()
    with pytest.raises(ValueError, match="exactly 2 Axes"):
        profile_figure(profile_result, ax=ax)
    with pytest.raises(KeyError, match="profiled: m, k"):
        profile_figure(profile_result, "q")
