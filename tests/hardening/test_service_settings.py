"""Settings as documented: host and port from the environment, offline docs, OPTIONS, report
images that a browser can load when a token is set, and a clear 404 for an over-long file name.
"""

from __future__ import annotations

import base64
import os
import re
import subprocess
import sys
import time

import httpx
import pytest

from api_helpers import Service, free_port, msd_spec
from fmuid.api.results import FitResultOut, ProfileResultOut
from plots.toy import toy_profile_result

pytestmark = pytest.mark.slow

TOKEN = "s3cret"
BEARER = {"Authorization": f"Bearer {TOKEN}"}


@pytest.fixture(scope="module")
def secured(tmp_path_factory: pytest.TempPathFactory):
    service = Service(tmp_path_factory.mktemp("secured"), FMUID_API_TOKEN=TOKEN).start()
    yield service
    service.stop()


@pytest.fixture(scope="module")
def done_job(secured, step_csv) -> str:
    client = secured.client()
    job = client.submit("fit", msd_spec(), [step_csv], model="msd")
    assert client.wait(job, timeout=300)["status"] == "done"
    return job


def test_serve_listens_where_the_environment_says(tmp_path):
    port = free_port()
    env = {**os.environ, "FMUID_PORT": str(port), "FMUID_HOST": "127.0.0.1"}
    env["FMUID_DATA_DIR"] = str(tmp_path)
    command = [sys.executable, "-c", "import sys; from fmuid.cli import main; sys.exit(main())"]
    with open(tmp_path / "serve.log", "wb") as log:
        proc = subprocess.Popen([*command, "serve"], env=env, stdout=log, stderr=log)
    response = None
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                response = httpx.get(f"http://127.0.0.1:{port}/v1/health", timeout=1)
                break
            except httpx.TransportError:
                time.sleep(0.2)
        assert response is not None, (tmp_path / "serve.log").read_text()
        assert response.status_code == 200
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_docs_load_nothing_from_elsewhere(secured):
    page = httpx.get(secured.url + "/docs")
    assert page.status_code == 200
    sources = re.findall(r'(?:src|href)="([^"]+)"', page.text)
    assert sources and all(source.startswith("/") for source in sources), sources
    for source in sources:
        asset = httpx.get(secured.url + source)
        assert asset.status_code == 200 and len(asset.content) > 1000, source


def test_options_answered_and_documented(secured):
    schema = httpx.get(secured.url + "/openapi.json").json()
    for path, operations in schema["paths"].items():
        assert "options" in operations, path
        assert "204" in operations["options"]["responses"]
    response = httpx.options(secured.url + "/v1/jobs/x", headers=BEARER)
    assert response.status_code == 204
    assert response.headers["Allow"] == "DELETE, GET, OPTIONS"
    assert "400" in schema["paths"]["/v1/jobs"]["post"]["responses"]


def test_report_figures_are_embedded_and_files_need_the_token(secured, done_job):
    page = httpx.get(f"{secured.url}/v1/jobs/{done_job}/report", headers=BEARER)
    assert page.status_code == 200
    images = re.findall(r'<img src="([^"]+)"', page.text)
    # the figures travel inside the page (a saved page keeps them), as PNG data
    assert images and all(image.startswith("data:image/png;base64,") for image in images)
    assert base64.b64decode(images[0].partition(",")[2]).startswith(b"\x89PNG")
    base = f"{secured.url}/v1/jobs/{done_job}/report/"
    assert httpx.get(base + "diagnose_fit.png").status_code == 401  # no token, no signature
    assert httpx.get(base + "diagnose_fit.png?sig=" + "0" * 32).status_code == 401


def test_over_long_report_file_name_is_404(secured, done_job):
    response = httpx.get(f"{secured.url}/v1/jobs/{done_job}/report/{'a' * 300}.png", headers=BEARER)
    assert response.status_code == 404
    assert "no file" in response.json()["detail"]


def test_results_and_spec_are_typed_in_the_schema(secured, done_job):
    schema = httpx.get(secured.url + "/openapi.json").json()
    result = schema["paths"]["/v1/jobs/{job_id}/result"]["get"]["responses"]["200"]
    refs = {
        r["$ref"].rsplit("/", 1)[-1]
        for r in result["content"]["application/json"]["schema"]["anyOf"]
    }
    assert refs == {"FitResultOut", "ProfileResultOut", "DiagnosisOut", "DesignResultOut"}
    form = schema["components"]["schemas"]["Body_create_job_v1_jobs_post"]["properties"]
    assert form["spec"]["contentSchema"] == {"$ref": "#/components/schemas/Spec"}
    assert {"parameters", "outputs"} <= set(schema["components"]["schemas"]["Spec"]["properties"])
    fit = httpx.get(f"{secured.url}/v1/jobs/{done_job}/result", headers=BEARER).json()
    assert FitResultOut.model_validate(fit).parameters["k"].estimate == pytest.approx(4.4, rel=0.05)


def test_profile_model_reads_a_profile_result():
    result = toy_profile_result()
    typed = ProfileResultOut.model_validate(result.to_dict())
    assert set(typed.parameters) == set(result.parameters)
    assert typed.parameters["m"].ci.simultaneous == result.parameters["m"].ci_simultaneous
