"""Bad submissions get a 4xx naming the problem, checked before anything is queued."""

from __future__ import annotations

import json
from pathlib import Path

import httpx
import pytest

from api_helpers import member, msd_spec, multipart, rewrite_fmu, zip_bomb


def post(
    url: str,
    *,
    spec: str | None = None,
    data: list[tuple[str, bytes]] | None = None,
    fmu: tuple[str, bytes] | None = None,
    model: str | None = "msd",
    kind: str = "fit",
) -> httpx.Response:
    form = {"kind": kind, "spec": spec if spec is not None else msd_spec()}
    if model is not None:
        form["model"] = model
    files = [("data", (name, content, "text/csv")) for name, content in (data or [])]
    if fmu is not None:
        files.append(("fmu", (fmu[0], fmu[1], "application/zip")))
    return httpx.post(url + "/v1/jobs", data=form, files=files, timeout=60)


def detail(response: httpx.Response) -> str:
    body = response.json()["detail"]
    return body if isinstance(body, str) else json.dumps(body)


@pytest.fixture(scope="module")
def csv(step_csv: Path) -> bytes:
    return step_csv.read_bytes()


def test_nothing_queued_by_bad_uploads(service, csv):
    before = httpx.get(service.url + "/v1/jobs").json()["jobs"]
    post(service.url, data=[("step.csv", b"time,f,x\n0,1,nan\n")])
    assert httpx.get(service.url + "/v1/jobs").json()["jobs"] == before


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        (b"", "empty"),
        (b"f,x\n1,2\n", "time"),
        (b"time,f,x\n0,40,0\n0.2,40,nan\n", "row 3"),
        (b"time,f,x\n0,40,0\n0.2,40,inf\n", "row 3"),
        (b"time,f,x\n0,40,0\n0,40,0.1\n", "time"),
        (b"time,f,x,bogus\n0,40,0,1\n0.2,40,0.1,1\n", "bogus"),
        (b"time,f,x\n0,40,0\n0.2,40,abc\n", "abc"),
    ],
    ids=["empty", "no-time", "nan", "inf", "non-monotone", "unknown-column", "text"],
)
def test_bad_csv_is_422_naming_file_and_problem(service, content, needle):
    response = post(service.url, data=[("bad.csv", content)])
    assert response.status_code == 422, response.text
    assert "bad.csv" in detail(response) and needle in detail(response)


def test_missing_output_column_is_422(service):
    response = post(service.url, data=[("noout.csv", b"time,f\n0,40\n0.2,40\n")])
    assert response.status_code == 422
    assert "x" in detail(response)


@pytest.mark.parametrize(
    ("spec", "needle"),
    [
        ("{not json", "spec"),
        (msd_spec().replace('"k"', '"k_typo"'), "k_typo"),
        (json.dumps({**json.loads(msd_spec()), "confidence": 1.5}), "confidence"),
        (
            json.dumps(
                {
                    **json.loads(msd_spec()),
                    "parameters": {"m": {"start": 1.1, "lower": 5, "upper": 1}},
                }
            ),
            "m",
        ),
        (
            json.dumps(
                {
                    **json.loads(msd_spec()),
                    "parameters": {"k": {"start": 4.4, "lower": 0.01, "upper": 10.0}},
                    "fixed": {"m": "heavy"},
                }
            ),
            "fixed.m: 'm' is a Real parameter; 'heavy' does not fit",
        ),
    ],
    ids=["invalid-json", "unknown-parameter", "confidence", "lower>upper", "fixed-type"],
)
def test_bad_spec_is_422_naming_the_field(service, csv, spec, needle):
    response = post(service.url, spec=spec, data=[("step.csv", csv)])
    assert response.status_code == 422, response.text
    assert needle in detail(response)


def test_not_a_zip(service, csv):
    response = post(service.url, data=[("step.csv", csv)], fmu=("model.fmu", b"hello"), model=None)
    assert response.status_code == 422
    assert "model.fmu" in detail(response) and "zip" in detail(response)


def test_zip_slip(service, csv, msd_file, tmp_path):
    bad = rewrite_fmu(msd_file, tmp_path / "slip.fmu", {}, {"../../evil.sh": b"rm -rf /"})
    response = post(
        service.url, data=[("step.csv", csv)], fmu=("slip.fmu", bad.read_bytes()), model=None
    )
    assert response.status_code == 422
    assert "../../evil.sh" in detail(response)


def test_zip_bomb(service, csv, tmp_path):
    bomb = zip_bomb(tmp_path / "bomb.fmu")
    response = post(
        service.url, data=[("step.csv", csv)], fmu=("bomb.fmu", bomb.read_bytes()), model=None
    )
    assert response.status_code == 422
    assert "bomb" in detail(response)


@pytest.mark.parametrize("version", ["1.0", "3.0"])
def test_wrong_fmi_version(service, csv, msd_file, tmp_path, version):
    xml = member(msd_file, "modelDescription.xml").replace(
        b'fmiVersion="2.0"', f'fmiVersion="{version}"'.encode()
    )
    bad = rewrite_fmu(msd_file, tmp_path / "v.fmu", {"modelDescription.xml": xml})
    response = post(
        service.url, data=[("step.csv", csv)], fmu=("v.fmu", bad.read_bytes()), model=None
    )
    assert response.status_code == 422
    assert "v.fmu" in detail(response) and version in detail(response)


def test_no_linux64_binary(service, csv, msd_file, tmp_path):
    bad = rewrite_fmu(msd_file, tmp_path / "nobin.fmu", {"binaries/linux64/msd.so": None})
    response = post(
        service.url, data=[("step.csv", csv)], fmu=("nobin.fmu", bad.read_bytes()), model=None
    )
    assert response.status_code == 422
    assert "linux64" in detail(response)


def test_binary_that_does_not_load(service, csv, msd_file, tmp_path):
    bad = rewrite_fmu(msd_file, tmp_path / "junk.fmu", {"binaries/linux64/msd.so": b"\x7fELF junk"})
    response = post(
        service.url, data=[("step.csv", csv)], fmu=("junk.fmu", bad.read_bytes()), model=None
    )
    assert response.status_code == 422
    assert "does not load" in detail(response)


def test_unknown_model_and_fmu_xor_model(service, csv, msd_file):
    response = post(service.url, data=[("step.csv", csv)], model="nope")
    assert response.status_code == 422 and "nope" in detail(response)
    response = post(service.url, data=[("step.csv", csv)], model=None)
    assert response.status_code == 422 and "exactly one" in detail(response)
    both = post(service.url, data=[("step.csv", csv)], fmu=("msd.fmu", msd_file.read_bytes()))
    assert both.status_code == 422 and "exactly one" in detail(both)


def test_unknown_kind_and_duplicate_names(service, csv):
    assert post(service.url, data=[("step.csv", csv)], kind="optimise").status_code == 422
    response = post(service.url, data=[("step.csv", csv), ("step.csv", csv)])
    assert response.status_code == 422 and "step.csv" in detail(response)


def test_unknown_job_is_404(service):
    for method, path in [("GET", ""), ("GET", "/result"), ("GET", "/report"), ("DELETE", "")]:
        response = httpx.request(method, f"{service.url}/v1/jobs/no-such-job{path}")
        assert response.status_code == 404, (method, path)
        assert "no-such-job" in detail(response)


def test_result_409_while_not_done_then_cancel(service, csv):
    response = post(service.url, data=[("step.csv", csv)])
    assert response.status_code == 202, response.text
    assert response.json()["status"] == "queued"
    job = response.json()["id"]
    assert httpx.get(f"{service.url}/v1/jobs/{job}/result").status_code == 409
    cancelled = httpx.delete(f"{service.url}/v1/jobs/{job}").json()
    assert cancelled["status"] == "cancelled"
    status = httpx.get(f"{service.url}/v1/jobs/{job}").json()
    assert status["status"] == "cancelled" and status["error"]
    assert httpx.get(f"{service.url}/v1/jobs/{job}/result").status_code == 409
    assert httpx.get(service.url + "/v1/jobs").json()["jobs"][0]["id"] == job


def test_too_large_is_413_with_and_without_content_length(service_factory, csv):
    small = service_factory(FMUID_MAX_UPLOAD_BYTES="20000")
    big = csv * (30000 // len(csv) + 1)
    response = post(small.url, data=[("step.csv", big)])
    assert response.status_code == 413
    assert "20000" in detail(response)
    body, content_type = multipart(
        {"kind": "fit", "spec": msd_spec(), "model": "msd"}, [("data", "step.csv", big)]
    )

    def chunks():
        for i in range(0, len(body), 4096):
            yield body[i : i + 4096]

    response = httpx.post(
        small.url + "/v1/jobs", content=chunks(), headers={"Content-Type": content_type}
    )
    assert response.status_code == 413
    assert small.client().health()["status"] == "ok"


def test_openapi_and_docs(service):
    schema = httpx.get(service.url + "/openapi.json").json()
    assert {
        "/v1/jobs",
        "/v1/jobs/{job_id}",
        "/v1/jobs/{job_id}/result",
        "/v1/jobs/{job_id}/report",
        "/v1/health",
    } <= set(schema["paths"])
    assert httpx.get(service.url + "/docs").status_code == 200
