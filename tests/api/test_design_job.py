"""The API job kind ``design``: multipart ``space`` instead of ``data``."""

from __future__ import annotations

import json
import shutil

import pytest

from api_helpers import msd_spec
from design_cases import MSD_SPACE
from fmuid.client import ApiError
from fmuid.intake.vet import VetTask, vet


def test_design_job_returns_ranked_designs_and_a_report(service, tmp_path, step_csv):
    space = tmp_path / "E.json"
    space.write_text(json.dumps({**MSD_SPACE, "verify_designs": 0, "candidates": 2}))
    spec = msd_spec(0.02)
    client = service.client()
    job = client.submit("design", spec, [], model="msd", space_path=space)
    status = client.wait(job, timeout=300)
    assert status["status"] == "done", status
    result = client.result(job)
    assert result["designs"][0]["predicted"]["m"]["status"] == "identifiable"
    assert "Experiment design" in client.report(job)
    with pytest.raises(ApiError) as err:
        client.submit("design", spec, [], model="msd")
    assert err.value.status_code == 422 and "space" in str(err.value)
    with pytest.raises(ApiError) as err:
        client.submit("design", spec, [step_csv], model="msd", space_path=space)
    assert err.value.status_code == 422 and "data" in str(err.value)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**MSD_SPACE, "input": "u"}))
    with pytest.raises(ApiError) as err:
        client.submit("design", spec, [], model="msd", space_path=bad)
    assert err.value.status_code == 422 and "input: 'u' is not an FMU input" in str(err.value)


def test_design_space_is_checked_in_the_checking_process(tmp_path, msd_file):
    """The checking process reads the space: good passes, a wrong input or an oversized file not."""
    (tmp_path / "spec.json").write_text(msd_spec(0.02))
    shutil.copyfile(msd_file, tmp_path / "msd.fmu")

    def answer(space: str, **limits: int) -> dict:
        (tmp_path / "space.json").write_text(space)
        task = VetTask(str(tmp_path), [], "msd.fmu", None, 30.0, limits, space_file="space.json")
        return vet(task)

    good = json.dumps(MSD_SPACE)
    assert answer(good) == {"ok": True, "model_name": "msd"}
    wrong = answer(json.dumps({**MSD_SPACE, "input": "u"}))
    assert wrong["status"] == 422 and "input: 'u' is not an FMU input" in wrong["detail"]
    big = answer(good, max_spec_bytes=len(good) - 1)
    assert big["status"] == 422
    assert (
        big["detail"]
        == f"space: more than the limit of {len(good) - 1} bytes (FMUID_MAX_SPEC_BYTES)"
    )
