"""Bad submissions not covered by ``tests/api/test_uploads.py``: each a 422 naming the problem,
and nothing else disturbed (a good job submitted before and one submitted after both finish, and
the store holds exactly those two jobs, the first one's record unchanged by the bad requests).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import httpx
import pytest

from api_helpers import member, msd_spec, rewrite_fmu

pytestmark = pytest.mark.slow

SPEC = json.loads(msd_spec())


def spec_with(**changes: Any) -> str:
    return json.dumps({**SPEC, **changes})


def with_parameter(name: str, **bounds: float) -> str:
    return spec_with(parameters={**SPEC["parameters"], name: bounds})


def million_rows() -> bytes:
    return b"time,f,x\n" + b"".join(b"%d,40,0.5\n" % i for i in range(10**6))


def model_exchange_only(msd: Path, target: Path) -> Path:
    xml = member(msd, "modelDescription.xml").decode()
    start = xml.index("<CoSimulation")
    end = xml.index("/>", start) + 2
    xml = xml[:start] + '<ModelExchange modelIdentifier="msd" />' + xml[end:]
    return rewrite_fmu(msd, target, {"modelDescription.xml": xml.encode()})


def post(service: Any, spec: str, files: list[tuple[str, tuple[str, bytes]]]) -> httpx.Response:
    form = {"kind": "profile", "spec": spec}
    if not any(field == "fmu" for field, _ in files):
        form["model"] = "msd"
    return httpx.post(service.url + "/v1/jobs", data=form, files=files, timeout=120)


@pytest.fixture(scope="module")
def good_before(service, step_csv) -> dict[str, Any]:
    client = service.client()
    job = client.submit("fit", msd_spec(), [step_csv], model="msd")
    return client.status(job)


CASES = {
    "start-outside-bounds": (
        with_parameter("k", start=20.0, lower=0.01, upper=10.0),
        None,
        ["parameters.k.start", "20", "[0.01, 10.0]"],
    ),
    "negative-sigma": (
        spec_with(outputs={"x": {"sigma": -0.2}}),
        None,
        ["outputs.x.sigma", "-0.2"],
    ),
    "negative-sigma-column": (
        spec_with(outputs={"x": {"sigma": "column"}}),
        b"time,f,x,sigma_x\n0,40,0,0.2\n0.2,40,0.1,-0.2\n",
        ["bad.csv", "row 3", "sigma_x", "-0.2"],
    ),
    "confidence-zero": (spec_with(confidence=0), None, ["confidence", "0"]),
    "unknown-fixed-parameter": (spec_with(fixed={"zz": 1.0}), None, ["fixed.zz", "zz"]),
    "unknown-output": (spec_with(outputs={"y": {"sigma": 1.0}}), None, ["outputs", "'y'"]),
    "input-column-missing": (msd_spec(), b"time,x\n0,0\n0.2,0.1\n", ["bad.csv", "f"]),
    "million-rows": (msd_spec(), million_rows(), ["bad.csv", "200000 data rows"]),
}


@pytest.mark.parametrize(("spec", "csv", "needles"), CASES.values(), ids=CASES.keys())
def test_bad_submission_is_422_naming_the_problem(
    service, good_before, step_csv, spec, csv, needles
):
    data = ("bad.csv", csv) if csv is not None else ("step.csv", step_csv.read_bytes())
    response = post(service, spec, [("data", data)])
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert all(needle in detail for needle in needles), detail


def test_model_exchange_only_fmu_is_422(service, good_before, step_csv, msd_file, tmp_path):
    fmu = model_exchange_only(msd_file, tmp_path / "me.fmu")
    response = post(
        service,
        msd_spec(),
        [("data", ("step.csv", step_csv.read_bytes())), ("fmu", ("me.fmu", fmu.read_bytes()))],
    )
    assert response.status_code == 422, response.text
    assert "me.fmu" in response.json()["detail"]
    assert "does not export fmi2SetTime" in response.json()["detail"]


def test_nothing_else_disturbed(service, good_before, step_csv):
    client = service.client()
    after = client.submit("fit", msd_spec(), [step_csv], model="msd")
    for job in (good_before["id"], after):
        status = client.wait(job, timeout=300)
        assert status["status"] == "done", status
        assert client.result(job)["parameters"]["k"]["estimate"] == pytest.approx(4.4, rel=0.05)
    assert [j["id"] for j in client.list()] == [after, good_before["id"]]
    final = client.status(good_before["id"])
    unchanged = ("kind", "created", "model_name", "fmu_sha256", "datasets")
    assert {k: final[k] for k in unchanged} == {k: good_before[k] for k in unchanged}
