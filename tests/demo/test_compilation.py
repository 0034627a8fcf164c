import numpy as np

from fmuid.demo.compilation import CiEntry, ci_compilation_figure, ci_entries_from_profile
from plots.toy import toy_profile_result


def _gid(ax, gid):
    return [line for line in ax.lines if line.get_gid() == gid]


def test_compilation_bars_arrows_estimates_and_truth():
    profile_result = toy_profile_result()
    entries = ci_entries_from_profile(
        profile_result, "SNR 100", group="ramp", true_values={"m": 1.1, "k": 9.0}
    ) + ci_entries_from_profile(profile_result, "SNR 25", group="ramp")
    fig = ci_compilation_figure(entries, title="toy")
    ax_m, ax_k = fig.axes[:2]
    assert ax_m.get_title() == "m" and ax_k.get_title() == "k"
    assert len(_gid(ax_m, "ci_bar")) == 2
    assert len(_gid(ax_m, "estimate")) == 2
    (truth,) = _gid(ax_k, "true_value")
    assert np.allclose(truth.get_xdata(), 9.0)
    # k's upper CI end is null: its bars run to the upper bound and carry an arrow each
    bar = _gid(ax_k, "ci_bar")[0]
    assert bar.get_xdata()[1] == profile_result.parameters["k"].upper
    assert len(ax_k.texts) == 1 + 2  # the group heading and two arrows
    assert len(ax_m.texts) == 1
    assert [t.get_text() for t in ax_m.get_yticklabels()] == ["SNR 100", "SNR 25"]
    assert ax_m.get_xscale() == "log"


def test_compilation_groups_get_headings():
    entries = [
        CiEntry("C", f"SNR {s}", 2.0, (1.0, 3.0), 0.1, 10.0, group=g, true=2.0)
        for g in ("ramp 5 Hz", "chirp 5 Hz")
        for s in (1000, 25)
    ]
    ax = ci_compilation_figure(entries).axes[0]
    assert [t.get_text() for t in ax.texts] == ["ramp 5 Hz", "chirp 5 Hz"]
    assert len(_gid(ax, "true_value")) == 2
