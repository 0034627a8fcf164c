"""A real profile job's report, served by the service with a token set, opened in Chromium.

A browser sends no bearer token: the page opens through its signed link
(``GET /v1/jobs/{id}/report-link``), its figures are embedded, its link to the profile path's
CSV carries that file's own signature, and no other page, file or job opens with the page's.
"""

import json

import httpx
import numpy as np
import pytest

from api_helpers import Service
from fmuid.data import experiment_from_arrays
from fmuid.estimation.predictor import FmuPredictor
from report.browser import check_report_page, chromium

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}
TOKEN = "s3cret-report"


def _step_csv(msd_fmu, path):
    t = np.round(np.arange(51) * 0.2, 10)
    exp = experiment_from_arrays("step.csv", t, {"f": np.full(t.size, 40.0)})
    x = FmuPredictor(msd_fmu, {}, ["f"]).predict(TRUTH, exp, ["x"])[:, 0]
    x = x + np.random.default_rng(3).normal(0.0, 0.2, t.size)
    rows = ["time,f,x"] + [f"{ti:.6g},40,{xi:.9g}" for ti, xi in zip(t, x, strict=True)]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture
def secured(tmp_path):
    service = Service(tmp_path / "service", FMUID_API_TOKEN=TOKEN).start(timeout=90)
    yield service
    service.stop()


@pytest.mark.slow
def test_token_protected_report_opens_in_a_browser(secured, msd_fmu, tmp_path):
    spec = {
        "parameters": {n: {"start": v, "lower": 0.01, "upper": 10.0} for n, v in TRUTH.items()},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.2}},
        "global_search": False,
    }
    data = [_step_csv(msd_fmu, tmp_path / "step.csv")]
    with secured.client() as client:
        job = client.submit("profile", json.dumps(spec), data, fmu_path=msd_fmu)
        assert client.wait(job, timeout=600)["status"] == "done"
        url = client.report_url(job)
    other = "0" * 8 + job[8:]  # another job's id: the signature is checked before the job
    page = f"{secured.url}/v1/jobs/{job}/report"
    assert url.startswith(page + "?sig=")
    signature = url.partition("?")[2]
    assert httpx.get(page).status_code == 401
    tampered = ("1" if signature[4] == "0" else "0") + signature[5:]  # its first digit changed
    assert httpx.get(f"{page}?sig={tampered}").status_code == 401
    assert httpx.get(f"{secured.url}/v1/jobs/{other}/report?{signature}").status_code == 401
    assert httpx.get(f"{secured.url}/v1/jobs/{job}/result?{signature}").status_code == 401
    driver = chromium(tmp_path / "chromium-profile")
    try:
        check_report_page(driver, url, list(TRUTH), tmp_path / "service_report.png")
        sources = driver.execute_script("return Array.from(document.images).map(i => i.src)")
        assert all(s.startswith("data:image/png;base64,") for s in sources)
        links = driver.execute_script("return Array.from(document.links).map(a => a.href)")
        table = next(link for link in links if "/profile_path.csv?sig=" in link)
        assert httpx.get(table).text.startswith("parameter,value,chi2")  # signed: opens
        assert httpx.get(table.partition("?")[0]).status_code == 401
        driver.get(page)  # the bare page, without the signature
        assert "token" in driver.execute_script("return document.body.innerText")
    finally:
        driver.quit()
