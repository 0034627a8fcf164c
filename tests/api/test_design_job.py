"""The API job kind ``design``: multipart ``space`` instead of ``data``."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from api_helpers import msd_spec

from fmuid.client import ApiError

sys.path.insert(0, str(Path(__file__).parents[1] / "design"))
from design_cases import MSD_SPACE  # noqa: E402


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
