import dataclasses

from matplotlib.backends.backend_agg import FigureCanvasAgg

from fmuid.demo.compilation import ci_compilation_figure, ci_entries_from_profile
from fmuid.plots import parameter_paths_figure, profile_figure
from plots.toy import toy_profile_result


def _with_units():
    result = toy_profile_result()
    fit = dataclasses.replace(result.fit, units={"m": "kg", "k": "N/m"})
    return dataclasses.replace(result, fit=fit)


def test_profile_and_path_axes_carry_the_units():
    result = _with_units()
    labels = [ax.get_xlabel() for ax in profile_figure(result).axes if ax.get_visible()]
    assert labels == ["log10(m [kg])", "log10(k [N/m])"]
    paths = parameter_paths_figure(result, "k")
    assert paths.axes[0].get_xlabel() == "log10(k [N/m])"
    width, height = paths.get_size_inches()
    assert width >= 7 and height >= 4  # readable at 100 dpi beside the page's 1200 px


def test_paths_figure_keeps_its_labels_inside():
    fig = parameter_paths_figure(_with_units(), "m")
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    box = fig.bbox
    renderer = canvas.get_renderer()
    ax = fig.axes[0]
    for text in (ax.xaxis.label, ax.yaxis.label, ax.title, *ax.get_legend().get_texts()):
        extent = text.get_window_extent(renderer)
        assert box.x0 <= extent.x0 and extent.x1 <= box.x1, text.get_text()
        assert box.y0 <= extent.y0 and extent.y1 <= box.y1, text.get_text()


def test_compilation_panels_name_the_unit():
    entries = ci_entries_from_profile(_with_units(), "SNR 25")
    titles = [ax.get_title() for ax in ci_compilation_figure(entries).axes if ax.get_visible()]
    assert titles == ["m [kg]", "k [N/m]"]
