"""Progress as a user sees it: 80 columns, the refinement, a notebook's bars."""

import io
import re
import sys
import types

from rich.console import Console

import fmuid
from fmuid.console import ProgressDisplay
from fmuid.data import load_experiment, load_spec
from fmuid.progress import NotebookProgress, Progress, default_progress
from msd_study import write_msd_study

SIX = "C_atf 2/40, C_atr 3/40, C_ytf 2/40, C_ytr 1/40, sig_tf 2/40, sig_tr 2/40"


def _frame(events, width=80):
    """The lines of the bar's last frame in a terminal ``width`` columns wide."""
    out = io.StringIO()
    console = Console(file=out, width=width, force_terminal=True, color_system=None)
    with ProgressDisplay(tty=True, console=console) as show:
        for event in events:
            show(event)
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", out.getvalue())
    return [line for line in text.split("\r")[-1].splitlines() if line.strip()]


def test_six_parameters_keep_bar_count_and_clock_in_80_columns():
    lines = _frame(
        [
            Progress("fit", 25, 25, "genetic algorithm"),
            Progress("refine", 37, 0, "start 1/2, chi2 1234, 412 simulations"),
            Progress("profile", 12, 240, SIX),
        ]
    )
    assert len(lines) == 3 and all(len(line) <= 80 for line in lines)
    fit, refine, profile = (line.split() for line in lines)
    assert fit[:3] == ["fit", "\u2501" * 12, "25/25"] and fit[3] == "0:00:00"
    assert refine[0] == "refine" and refine[2] == "37/37"  # known once it is over
    assert profile[0] == "profile" and profile[2] == "240/240" and profile[3] == "0:00:00"
    assert profile[-1].endswith("\u2026")  # the detail gives way, ending in an ellipsis


def test_a_fit_reports_its_refinement(msd_fmu, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_msd_study(tmp_path)
    spec = load_spec("spec.json").model_copy(update={"global_search": False})
    events = []
    fmuid.fit(msd_fmu, [load_experiment("step.csv")], spec, progress=events.append)
    refine = [e for e in events if e.stage == "refine"]
    assert refine and refine[0].total == 0
    assert re.fullmatch(r"start 1/1, chi2 \S+, \d+ simulations", refine[0].detail)


def test_a_notebook_gets_bars_by_default(monkeypatch):
    assert default_progress(None) is None  # not in a notebook
    shell = types.SimpleNamespace(kernel=object())
    monkeypatch.setitem(sys.modules, "IPython", types.SimpleNamespace(get_ipython=lambda: shell))
    assert isinstance(default_progress(None), NotebookProgress)
    mine = print
    assert default_progress(mine) is mine
    shown = []
    bars = NotebookProgress(show=shown.append, interval=60.0)
    bars(Progress("fit", 1, 25, "genetic algorithm"))
    bars(Progress("fit", 2, 25, "genetic <algorithm>"))  # within the interval: not drawn
    bars(Progress("fit", 25, 25, "genetic <algorithm>"))  # the end of a stage always is
    assert len(shown) == 2
    assert '<progress value="25" max="25"></progress> 25/25 0:00' in shown[-1]
    assert "genetic &lt;algorithm&gt;" in shown[-1]
