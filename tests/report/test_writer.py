import html
import re
from dataclasses import replace
from html.parser import HTMLParser

from fmuid.profiling.result import ProfileQuality
from fmuid.report import write_report
from plots.toy import toy_fit, toy_profile_result


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images: list[str] = []
        self.tables: dict[str, list[list[str]]] = {}
        self._table: str | None = None
        self._cell: list[str] | None = None
        self.links: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a["src"])
        if tag in ("link", "script") or (tag == "img" and "://" in a["src"]):
            self.links.append(tag)
        if tag == "table":
            self._table = a.get("id", f"t{len(self.tables)}")
            self.tables[self._table] = []
        if tag == "tr" and self._table:
            self.tables[self._table].append([])
        if tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None and self._table:
            self.tables[self._table][-1].append("".join(self._cell))
            self._cell = None
        if tag == "table":
            self._table = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def _parse(path):
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def test_profile_report_lists_parameters_and_images_exist(tmp_path):
    result = toy_profile_result()
    path = write_report(result, tmp_path / "r")
    assert path == tmp_path / "r" / "index.html"
    page = _parse(path)
    assert page.images, "no figure"
    # the profile figure and one parameter-path figure per parameter
    assert len(page.images) == 1 + len(result.parameters)
    for src in page.images:
        assert (path.parent / src).stat().st_size > 1000
    rows = page.tables["summary"][1:]
    assert [r[0] for r in rows] == list(result.parameters)
    k = rows[1]
    assert k[5] == "practically non identifiable"
    assert k[3].endswith("+\u221e]")
    study = dict((r[0], r[1]) for r in page.tables["study"][1:])
    assert study["threshold simultaneous (chi2 rise)"] == "2.28"
    assert study["sigma x"] == "0.1 (given)"
    assert not page.links  # self-contained: no external style sheets, scripts or images


def test_fit_report(tmp_path):
    path = write_report(toy_fit(), tmp_path)
    page = _parse(path)
    assert [r[0] for r in page.tables["summary"][1:]] == ["m", "k"]
    assert page.images == []


class _Diagnosis:
    def to_dict(self):
        return {
            "mismatch": True,
            "evidence": [{"test": "residual_whiteness", "output": "gam_t", "p_value": 1e-6}],
            "location": {"outputs": ["gam_t"], "time_windows": [[1.0, 3.2]]},
            "effect": "output_lag",
            "description": "Lag <script>alert(1)</script> & more",
            "candidates": [{"effect": "output_lag", "chi2": 101.0}],
            "added_parameters": {"tau_outputs": {"estimate": 0.12, "ci": [0.10, None]}},
            "chi2_before": 640.2,
            "chi2_after": 101.0,
            "parameters": {"C_atf": {"before": 1.8e5, "after": 2.21e5}, "C_atr": {}},
        }


def test_diagnosis_report_escapes_text(tmp_path):
    path = write_report(_Diagnosis(), tmp_path)
    text = path.read_text()
    assert "<script>" not in text
    assert html.escape("Lag <script>alert(1)</script> & more") in text
    page = _parse(path)
    assert [r[0] for r in page.tables["summary"][1:]] == ["C_atf", "C_atr"]
    assert re.search(r"0\.1, \+\u221e", text)


def test_profile_report_shows_each_label_reason_and_quality(tmp_path):
    result = toy_profile_result()
    k = result.parameters["k"]
    quality = ProfileQuality(checks=2, starts=8, lower_valleys=1, rewalks=1, unsettled=("x y",))
    k = replace(k, status_reason="the upper end is open: flat up to the bound", quality=quality)
    result = replace(result, parameters={**result.parameters, "k": k})
    page = _parse(write_report(result, tmp_path))
    header, m_row, k_row = page.tables["summary"]
    why, checked = header.index("why"), header.index("quality")
    assert k_row[why] == "the upper end is open: flat up to the bound"
    assert k_row[checked] == (
        "not settled: x y (2 valley checks, 8 starts, 1 lower valley, 1 re-walk)"
    )
    assert m_row[checked] == "settled"


def test_dollar_signs_in_names_are_plain_text(tmp_path):
    odd = "m$^$"  # mathtext cannot parse this
    result = toy_profile_result()
    parameters = {odd: replace(result.parameters["m"], name=odd)}
    result = replace(result, parameters={**parameters, "k": result.parameters["k"]})
    page = _parse(write_report(result, tmp_path / "r"))
    assert len(page.images) == 1 + len(result.parameters)
    assert odd in [row[0] for row in page.tables["summary"][1:]]
