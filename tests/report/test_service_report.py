import json
import os
import socket
import subprocess
import sys
import time

import httpx
import numpy as np
import pytest

from fmuid.client import FmuidClient
from fmuid.data import experiment_from_arrays
from fmuid.estimation.predictor import FmuPredictor
from report.browser import check_report_page, chromium

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}


def _step_csv(msd_fmu, path):
    t = np.round(np.arange(51) * 0.2, 10)
    exp = experiment_from_arrays("step.csv", t, {"f": np.full(t.size, 40.0)})
    x = FmuPredictor(msd_fmu, {}, ["f"]).predict(TRUTH, exp, ["x"])[:, 0]
    x = x + np.random.default_rng(3).normal(0.0, 0.2, t.size)
    rows = ["time,f,x"] + [f"{ti:.6g},40,{xi:.9g}" for ti, xi in zip(t, x, strict=True)]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture
def service_url(tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "FMUID_DATA_DIR": str(tmp_path / "service")}
    env.pop("FMUID_API_TOKEN", None)
    with open(tmp_path / "service.log", "wb") as log:
        process = subprocess.Popen(
            [sys.executable, "-m", "fmuid.api", "--port", str(port)],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and process.poll() is None:
        try:
            if httpx.get(url + "/v1/health", timeout=1.0).status_code == 200:
                break
        except httpx.TransportError:
            time.sleep(0.1)
    yield url
    process.terminate()
    process.wait(timeout=20)


@pytest.mark.slow
def test_profile_job_report_served_by_the_service(service_url, msd_fmu, tmp_path):
    spec = {
        "parameters": {n: {"start": v, "lower": 0.01, "upper": 10.0} for n, v in TRUTH.items()},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.2}},
        "global_search": False,
    }
    with FmuidClient(service_url) as client:
        job = client.submit(
            "profile", json.dumps(spec), [_step_csv(msd_fmu, tmp_path / "step.csv")], model="msd"
        )
        assert client.wait(job, timeout=600)["status"] == "done"
    driver = chromium(tmp_path / "chromium-profile")
    try:
        check_report_page(
            driver,
            f"{service_url}/v1/jobs/{job}/report",
            list(TRUTH),
            tmp_path / "service_report.png",
        )
    finally:
        driver.quit()
