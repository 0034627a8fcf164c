import re
from html.parser import HTMLParser

import pytest

from fmuid.demo import NOMINAL, run_demo
from report.test_report_text import check, collect_figure_texts


class _Images(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images: list[str] = []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs)["src"])


@pytest.mark.slow
def test_small_grid_demo_writes_the_study_report(tmp_path, monkeypatch):
    figure_texts = collect_figure_texts(monkeypatch)
    lines: list[str] = []
    index = run_demo(tmp_path / "demo", grid="small", workers=2, progress=lines.append)
    assert index == tmp_path / "demo" / "index.html"
    assert lines[-1].endswith(str(index))
    assert sum("done in" in line for line in lines) == 4
    text = index.read_text(encoding="utf-8")
    parser = _Images()
    parser.feed(text)
    assert len(parser.images) >= 6
    for src in parser.images:  # embedded PNGs
        assert src.startswith("data:image/png;base64,") and len(src) > 1000
    # the Table 3.3 comparison lists every tire parameter; at SNR 1000 the simultaneous CIs
    # of C_atf, C_atr and sig_tf contain the true values, as in the thesis
    table = re.search(r'<table id="summary">(.*?)</table>', text, re.S).group(1)
    rows = {
        cells[0]: cells
        for cells in (re.findall(r"<td[^>]*>(.*?)</td>", row) for row in table.split("</tr>"))
        if cells
    }
    assert list(rows) == list(NOMINAL)
    for name in ("C_atf", "C_atr", "sig_tf"):
        low, high = (float(v) for v in rows[name][6].strip("[]").split(", "))
        assert low < NOMINAL[name] < high
    assert "Experiment advice" in text
    assert "seed 0" in text and "sigma = max|gam_t| / SNR" in text
    assert any(line.startswith("drawing the per-dataset reports: 4/4") for line in lines)
    assert len(list((tmp_path / "demo").glob("*/index.html"))) == 4
    check([index], figure_texts, tmp_path)  # last: skipped where Chromium is not installed
