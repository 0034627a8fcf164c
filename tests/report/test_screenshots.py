"""Profile and diagnose reports of real msd studies, opened in headless Chromium.

The DOM is checked for units and for Python literals; full-page screenshots are saved in the
test's tmp dir (``profile.png``, ``diagnose.png``) for a person to look at.
"""

import json

import numpy as np
import pytest

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.discrepancy import diagnose
from fmuid.estimation.predictor import FmuPredictor
from fmuid.report import write_report
from report.browser import chromium

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}
UNITS = {"m": "kg", "k": "N/m", "b": "N.s/m"}  # msd's model_src/msd/variables.json
SIGMA = 0.02


def _lagged(x: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """Exact discrete first-order lag of a signal held between samples (independent of fmuid)."""
    a = np.exp(-dt / tau)
    y = np.empty_like(x)
    y[0] = x[0]
    for i in range(1, x.size):
        y[i] = a * y[i - 1] + (1 - a) * x[i]
    return y


def _study(msd_fmu, lag: float | None):
    t = np.round(np.arange(61) * 0.1, 10)
    f = np.where(t >= 0.5, 10.0, 0.0) + 5.0 * np.sin(2 * np.pi * 0.5 * t)
    inputs = experiment_from_arrays("step.csv", t, {"f": f})
    x = FmuPredictor(msd_fmu, {}, ["f"]).predict(TRUTH, inputs, ["x"])[:, 0]
    if lag:
        x = _lagged(x, 0.1, lag)
    x = x + np.random.default_rng(1).normal(0.0, SIGMA, t.size)
    experiment = experiment_from_arrays("step.csv", t, {"f": f, "x": x})
    spec = {
        "parameters": {n: {"start": v, "lower": 0.1, "upper": 20.0} for n, v in TRUTH.items()},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": SIGMA}},
        "global_search": False,
    }
    return [experiment], spec_from_json(json.dumps(spec))


def _open(driver, path, screenshot):
    from selenium.webdriver.support.ui import WebDriverWait

    driver.get(path.as_uri())
    WebDriverWait(driver, 30).until(
        lambda d: d.execute_script(
            "return document.readyState === 'complete' && "
            "Array.from(document.images).every(i => i.complete && i.naturalWidth > 0)"
        )
    )
    height = driver.execute_script("return document.documentElement.scrollHeight")
    driver.set_window_size(1300, min(int(height) + 100, 16000))
    driver.save_screenshot(str(screenshot))
    assert screenshot.stat().st_size > 10_000
    text = driver.execute_script("return document.body.innerText")
    assert "{'" not in text and "': " not in text, "a Python literal reached the page"
    return text


def _table(driver, table_id):
    return driver.execute_script(
        "return Array.from(document.querySelectorAll(arguments[0] + ' tr')).map("
        "r => Array.from(r.cells).map(c => c.innerText))",
        f"table#{table_id}",
    )


@pytest.fixture
def driver(tmp_path):
    browser = chromium(tmp_path / "chromium-profile")
    yield browser
    browser.quit()


@pytest.mark.slow
def test_profile_report_shows_units_and_no_literals(driver, msd_fmu, tmp_path):
    experiments, spec = _study(msd_fmu, lag=None)
    result = fmuid.profile(msd_fmu, experiments, spec, workers=1)
    index = write_report(
        result, tmp_path / "profile", fmu=msd_fmu, experiments=experiments, spec=spec
    )
    text = _open(driver, index, tmp_path / "profile.png")
    verdict = driver.execute_script("return document.querySelector('#verdict').innerText")
    assert text.index(verdict) < text.index("Summary"), "the verdict comes first"
    rows = _table(driver, "summary")
    header, body = rows[0], rows[1:]
    assert header[:3] == ["parameter", "unit", "estimate"]
    assert "quality" in header and "why" in header
    assert {r[0]: r[1] for r in body} == UNITS
    assert all(r[header.index("quality")].startswith(("settled", "not settled")) for r in body)
    study = {r[0]: r[1] for r in _table(driver, "study")[1:]}
    assert study["sigma x"].startswith(f"{SIGMA:g} m ")
    assert json.loads(json.dumps(result.to_dict()))["units"] == {**UNITS, "f": "N", "x": "m"}


@pytest.mark.slow
def test_diagnose_report_shows_units_and_no_literals(driver, msd_fmu, tmp_path):
    experiments, spec = _study(msd_fmu, lag=0.15)
    diagnosis = diagnose(msd_fmu, experiments, spec)
    assert diagnosis.mismatch
    index = write_report(
        diagnosis, tmp_path / "diagnose", fmu=msd_fmu, experiments=experiments, spec=spec
    )
    text = _open(driver, index, tmp_path / "diagnose.png")
    assert text.index(diagnosis.to_dict()["verdict"]) < text.index("Summary")
    rows = _table(driver, "summary")
    assert rows[0] == ["parameter", "unit", "before", "after"]
    units = {r[0]: r[1] for r in rows[1:]}
    assert {n: units[n] for n in TRUTH} == UNITS
    assert all(units[n] == "s" for n in diagnosis.added_parameters if n.startswith("tau"))
    assert "time windows [s]" in text
    assert diagnosis.to_dict()["units"]["x"] == "m"
