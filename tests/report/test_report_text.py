"""Every report kind reads as text a person can read: no raw math text, nan, inf, p = 0 or −∞.

The demo's report (small grid) is checked the same way in ``tests/test_demo.py``.

Each report is drawn from a real (small) study; the page's text is read from its HTML and in
headless Chromium (skipped with the reason where Chromium is not installed), and the text of
every figure (titles, labels, tick labels, legends) from matplotlib after drawing.
"""

import html
import json
import re
from dataclasses import replace

import numpy as np
import pytest
from matplotlib.text import Text

import fmuid
from design_cases import MSD_SPEC, SMALL, space_of
from fmuid.data import spec_from_json
from fmuid.readable import duration, interval, p_text, p_value
from fmuid.report import page as page_module
from fmuid.report import write_report
from report.browser import chromium
from report.test_screenshots import _study

UNREADABLE = {
    "raw math text": re.compile(r"\$[^$]*\\|\\mathdefault"),
    "nan": re.compile(r"\bnan\b", re.I),
    "inf": re.compile(r"\binf\b", re.I),
    "p = 0": re.compile(r"\bp = 0(?![.\d])"),
    "minus infinity": re.compile("\u2212\u221e|-\u221e"),
}


def unreadable(text: str) -> list[str]:
    """Name each kind of unreadable text found in ``text``."""
    return [name for name, pattern in UNREADABLE.items() if pattern.search(text)]


def test_the_patterns_catch_what_they_should():
    assert unreadable(r"$\mathdefault{10^{2}}$") == ["raw math text"]
    assert unreadable("chi2 nan, CI [−∞, inf], p = 0") == ["nan", "inf", "p = 0", "minus infinity"]
    assert unreadable("p = 0.013; information; banana") == []


def test_numbers_read_as_a_person_writes_them():
    assert p_value(0.0) == "< 1e-300" and p_text(0.0) == "p < 1e-300"
    assert p_text(5e-301) == "p < 1e-300" and p_text(0.0123) == "p = 0.012"
    assert p_value(float("nan")) == p_value(None) == "\u2014"
    assert interval((None, 1.7241)) == "[open, 1.724]"
    assert interval((-np.inf, np.inf)) == "[open, open]"
    assert [duration(s) for s in (8.08378, 275.4, 413.0, 7200.0)] == [
        "8.08 s",
        "275 s",
        "413 s",
        "2 h",
    ]


def collect_figure_texts(monkeypatch) -> list[str]:
    """Return a list that collects the visible text of every figure a report embeds."""
    texts: list[str] = []
    original = page_module.HtmlPage.figure

    def figure(self, fig, name, caption):
        path = original(self, fig, name, caption)  # drawn by savefig, tick labels included
        texts.extend(t.get_text() for t in fig.findobj(Text) if t.get_visible() and t.get_text())
        return path

    monkeypatch.setattr(page_module.HtmlPage, "figure", figure)
    return texts


@pytest.fixture
def figure_texts(monkeypatch):
    """Collect the visible text of every figure a report embeds."""
    return collect_figure_texts(monkeypatch)


def html_text(index) -> str:
    """The text of a page's body, tags removed and entities decoded."""
    body = index.read_text(encoding="utf-8").split("<body>", 1)[1]
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


def check(indexes, texts, tmp_path):
    """Assert that the pages and their figures read cleanly: their HTML, then in Chromium.

    Where Chromium (or selenium) is not installed the test is skipped after the HTML check,
    with the reason.
    """
    for index in indexes:
        text = html_text(index)
        assert text.strip() and unreadable(text) == [], (index, text)
    bad = {t: unreadable(t) for t in texts if unreadable(t)}
    assert texts and not bad, bad
    driver = chromium(tmp_path / "chromium-profile")
    try:
        for index in indexes:
            driver.get(index.as_uri())
            shown = driver.execute_script("return document.body.innerText")
            assert shown.strip() and unreadable(shown) == [], (index, shown)
    finally:
        driver.quit()


@pytest.mark.slow
def test_fit_and_profile_reports_read_cleanly(msd_fmu, tmp_path, figure_texts):
    experiments, spec = _study(msd_fmu, lag=None)
    problem_inputs = {"fmu": msd_fmu, "experiments": experiments, "spec": spec}
    result = fmuid.profile(msd_fmu, experiments, spec, workers=1)
    fit = write_report(result.fit, tmp_path / "fit", **problem_inputs)
    profile = write_report(result, tmp_path / "profile", **problem_inputs)
    check([fit, profile], figure_texts, tmp_path)
    # the result carries its problem: the same figures without the inputs, fewer without it
    carried = write_report(result, tmp_path / "carried").parent
    bare = write_report(replace(result, problem=None), tmp_path / "bare").parent
    figures = sorted(f.name for f in (tmp_path / "profile").glob("*.png"))
    assert sorted(f.name for f in carried.glob("*.png")) == figures
    assert len(list(bare.glob("*.png"))) < len(figures)


@pytest.mark.slow
@pytest.mark.parametrize("lag", [None, 0.15], ids=["no_mismatch", "mismatch"])
def test_diagnose_reports_read_cleanly(msd_fmu, tmp_path, figure_texts, lag):
    experiments, spec = _study(msd_fmu, lag=lag)
    diagnosis = fmuid.diagnose(msd_fmu, experiments, spec)
    assert diagnosis.mismatch == (lag is not None)
    index = write_report(diagnosis, tmp_path / "diagnose")  # the problem it carries
    text = index.read_text(encoding="utf-8")
    if lag is None:  # only what applies: no location, no before/after
        assert "Location of the mismatch" not in text and "augmented" not in text
    else:
        assert "Location of the mismatch" in text
    check([index], figure_texts, tmp_path)


@pytest.mark.slow
def test_design_report_reads_cleanly(tmp_path, figure_texts):
    result = fmuid.design("msd", spec_from_json(json.dumps(MSD_SPEC)), space_of(**SMALL))
    check([write_report(result, tmp_path / "design")], figure_texts, tmp_path)
