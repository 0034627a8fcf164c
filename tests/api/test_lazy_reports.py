"""Reports are drawn on their first request: once under concurrent first requests, in a process.

A done job has its result but no report until someone asks; then exactly one drawing process
draws it (its log line is counted in the job's log) however many requests arrive together, and
later requests serve the same files. A report that cannot be drawn answers a JSON error naming
the cause and leaves the job ``done`` with its result.
"""

from __future__ import annotations

import sqlite3
import time
from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest

from api_helpers import msd_spec
from fmuid.api.drawing import RETRY_AFTER_S

DRAWING_LINE = "drawing the report of job"


@pytest.fixture
def done_job(service, step_csv) -> str:
    client = service.client()
    job = client.submit("fit", msd_spec(), [step_csv], model="msd")
    assert client.wait(job, timeout=300)["status"] == "done"
    return job


def drawings(service, job: str) -> int:
    return (service.data_dir / "logs" / f"{job}.log").read_text().count(DRAWING_LINE)


def test_concurrent_first_requests_draw_once(service, done_job):
    assert not (service.data_dir / "reports" / done_job).exists()  # the job drew nothing
    url = f"{service.url}/v1/jobs/{done_job}/report"
    with ThreadPoolExecutor(6) as pool:
        answers = list(pool.map(lambda _: httpx.get(url, timeout=120), range(6)))
    assert [a.status_code for a in answers] == [200] * 6, [a.text[:200] for a in answers]
    assert len({a.text for a in answers}) == 1 and "<html" in answers[0].text.lower()
    assert "default-src 'none'" in answers[0].headers["content-security-policy"]
    assert drawings(service, done_job) == 1
    images = sorted(p.name for p in (service.data_dir / "reports" / done_job).glob("*.png"))
    assert images
    image = httpx.get(f"{url}/{images[0]}", timeout=60)
    assert image.status_code == 200 and image.content.startswith(b"\x89PNG")
    assert drawings(service, done_job) == 1


def test_first_request_of_a_file_draws_the_report(service, done_job):
    answer = httpx.get(f"{service.url}/v1/jobs/{done_job}/report/nothing.png", timeout=120)
    assert answer.status_code == 404 and "nothing.png" in answer.json()["detail"]
    assert (service.data_dir / "reports" / done_job / "index.html").is_file()
    assert drawings(service, done_job) == 1


def test_a_failed_drawing_names_the_cause_and_is_tried_again(service, done_job):
    with sqlite3.connect(service.data_dir / "jobs.sqlite") as db:
        (result,) = db.execute("SELECT json FROM results WHERE job_id = ?", (done_job,)).fetchone()
        db.execute("UPDATE results SET json = '{\"chi2\": 1.0}' WHERE job_id = ?", (done_job,))
    url = f"{service.url}/v1/jobs/{done_job}/report"
    answer = httpx.get(url, timeout=120)
    assert answer.status_code == 503, answer.text
    detail = answer.json()["detail"]
    assert detail.startswith(f"the report of job {done_job} could not be drawn: ")
    assert "SpecError: not an fmuid result" in detail, detail
    status = httpx.get(f"{service.url}/v1/jobs/{done_job}", timeout=10).json()
    assert status["status"] == "done" and status["error"] is None
    assert httpx.get(url, timeout=60).json()["detail"] == detail  # the cause stays a moment
    assert drawings(service, done_job) == 1
    with sqlite3.connect(service.data_dir / "jobs.sqlite") as db:  # the cause has passed
        db.execute("UPDATE results SET json = ? WHERE job_id = ?", (result, done_job))
    time.sleep(RETRY_AFTER_S + 0.5)
    answer = httpx.get(url, timeout=120)
    assert answer.status_code == 200 and "<html" in answer.text.lower(), answer.text
    assert drawings(service, done_job) == 2
