"""The HTTP API in-process: FastAPI's TestClient against an app built here, no server process.

Fast checks of the routes, the token and the errors a client gets; the tests beside this one
run the real service (uvicorn in its own process) end to end.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from api_helpers import msd_csv, msd_spec
from fmuid.api.app import create_app
from fmuid.settings import Settings

TOKEN = "in-process-token"


@pytest.fixture
def client(tmp_path: Path) -> Iterator[TestClient]:
    settings = Settings(
        data_dir=tmp_path / "data", api_token=TOKEN, warm_start=False, max_upload_bytes=200_000
    )
    with TestClient(create_app(settings)) as test_client:
        yield test_client


def auth() -> dict[str, str]:
    return {"Authorization": f"Bearer {TOKEN}"}


def submit(client: TestClient, csv: Path, spec: str | None = None, **form: str):
    with open(csv, "rb") as data:
        return client.post(
            "/v1/jobs",
            data={"kind": "fit", "spec": spec or msd_spec(), "model": "msd", **form},
            files=[("data", ("step.csv", data, "text/csv"))],
            headers=auth(),
        )


def test_health_needs_no_token_and_gives_the_queue(client):
    answer = client.get("/v1/health")
    assert answer.status_code == 200
    body = answer.json()
    assert (body["status"], body["queued"], body["running"]) == ("ok", 0, 0)


def test_every_other_route_needs_the_token(client):
    for path in ("/v1/jobs", "/v1/jobs/abc", "/v1/jobs/abc/result", "/v1/jobs/abc/report"):
        assert client.get(path).status_code == 401, path
        wrong = client.get(path, headers={"Authorization": "Bearer wrong"})
        assert wrong.status_code == 401, path
    assert client.get("/v1/jobs", headers=auth()).json() == {"jobs": []}


def test_unknown_job_is_404_naming_it(client):
    answer = client.get("/v1/jobs/no-such-job", headers=auth())
    assert answer.status_code == 404
    assert "no-such-job" in answer.json()["detail"]


def test_a_job_is_queued_listed_cancelled_and_has_no_result(client, tmp_path):
    answer = submit(client, msd_csv(tmp_path / "step.csv"))
    assert answer.status_code == 202, answer.text
    job = answer.json()
    assert job["status"] == "queued"
    listed = client.get("/v1/jobs", headers=auth()).json()["jobs"]
    assert [j["id"] for j in listed] == [job["id"]]
    assert listed[0]["kind"] == "fit"
    cancelled = client.delete(f"/v1/jobs/{job['id']}", headers=auth())
    assert cancelled.status_code == 200
    assert cancelled.json()["status"] == "cancelled"  # a cold job process takes seconds
    result = client.get(f"/v1/jobs/{job['id']}/result", headers=auth())
    assert result.status_code == 409
    assert "cancelled" in result.json()["detail"]


def test_bad_spec_and_kind_are_422_naming_the_field(client, tmp_path):
    csv = msd_csv(tmp_path / "step.csv")
    bad_spec = submit(client, csv, spec='{"parameters": {"m": {"start": "heavy"}}}')
    assert bad_spec.status_code == 422
    assert "start" in bad_spec.text
    bad_kind = submit(client, csv, kind="guess")
    assert bad_kind.status_code == 422
    assert "kind" in bad_kind.text


def test_an_upload_over_the_limit_is_413(client, tmp_path):
    big = tmp_path / "big.csv"
    rows = "\n".join(f"{k * 0.01:.2f},40,0" for k in range(30_000))
    big.write_text("time,f,x\n" + rows + "\n")
    answer = submit(client, big)
    assert answer.status_code == 413
    assert client.get("/v1/jobs", headers=auth()).json() == {"jobs": []}
