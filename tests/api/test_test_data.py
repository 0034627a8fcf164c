"""HTTP multipart ``test_data``: held-out CSV files checked and stored like ``data``."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from api_helpers import msd_csv, msd_spec
from fmuid.api.app import create_app
from fmuid.settings import Settings

TOKEN = "test-data-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


@pytest.fixture
def client(tmp_path: Path) -> Iterator[TestClient]:
    settings = Settings(data_dir=tmp_path / "data", api_token=TOKEN, warm_start=False)
    with TestClient(create_app(settings)) as test_client:
        yield test_client


def submit(client: TestClient, data: Path, tests: list[tuple[str, bytes]], kind: str = "fit"):
    return client.post(
        "/v1/jobs",
        data={"kind": kind, "spec": msd_spec(), "model": "msd"},
        files=[
            ("data", ("step.csv", data.read_bytes(), "text/csv")),
            *(("test_data", (name, body, "text/csv")) for name, body in tests),
        ],
        headers=AUTH,
    )


def test_a_bad_test_file_is_422_naming_it(client, tmp_path):
    data = msd_csv(tmp_path / "step.csv")
    answer = submit(client, data, [("held.csv", b"time,f,y\n0,40,0\n1,40,0\n")])
    assert answer.status_code == 422
    assert "held.csv" in answer.json()["detail"]
    assert "'y'" in answer.json()["detail"]
    design = submit(client, data, [("held.csv", data.read_bytes())], kind="design")
    assert design.status_code == 422
    assert "test_data" in design.json()["detail"]


@pytest.mark.slow
def test_a_fit_job_reports_the_validation_of_its_test_files(client, tmp_path):
    data = msd_csv(tmp_path / "step.csv")
    held = msd_csv(tmp_path / "held.csv", sigma=0.0, force=20.0).read_bytes()
    answer = submit(client, data, [("held.csv", held)])
    assert answer.status_code == 202, answer.text
    job_id = answer.json()["id"]
    job = client.get(f"/v1/jobs/{job_id}", headers=AUTH).json()
    assert [d["name"] for d in job["datasets"]] == ["step.csv", "test_data/held.csv"]
    deadline = time.monotonic() + 120
    while job["status"] in ("queued", "running") and time.monotonic() < deadline:
        time.sleep(0.5)
        job = client.get(f"/v1/jobs/{job_id}", headers=AUTH).json()
    assert job["status"] == "done", job
    result = client.get(f"/v1/jobs/{job_id}/result", headers=AUTH).json()
    (entry,) = result["validation"]
    assert (entry["experiment"], entry["output"], entry["n"]) == ("held.csv", "x", 51)
    # noise-free held-out step of half the force: the error is the fit's parameter error only
    assert 0 < entry["rms_base"] < 0.05
