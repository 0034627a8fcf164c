"""FMUs that fail at run time fail only their own job (or only their points), with a reason.

The segfaulting and hanging FMUs are covered in ``tests/api/test_jobs.py``; here: an FMU whose
``fmi2DoStep`` returns ``fmi2Error`` for some parameter values (the profile marks those points and
walks on), and one that allocates without bound (its job fails at the memory limit). After each,
the next job on the same service succeeds.
"""

from __future__ import annotations

import pytest

from api_helpers import MSD_TRUTH, msd_spec

pytestmark = pytest.mark.slow

# the stiffness band in which fmus_src/error_band fails (K_FAIL_LOW, K_FAIL_HIGH in its model.c)
K_FAIL = (4.404, 4.416)
MEMORY_MB = 768


def test_do_step_errors_mark_points_and_the_profile_walks_on(service, test_fmus, step_csv):
    client = service.client()
    job = client.submit("profile", msd_spec(), [step_csv], fmu_path=test_fmus["error_band"])
    status = client.wait(job, timeout=300)
    assert status["status"] == "done", status
    k = client.result(job)["parameters"]["k"]
    inside = [p for p in k["profile"] if K_FAIL[0] < p["value"] < K_FAIL[1]]
    beyond = [p for p in k["profile"] if p["value"] >= K_FAIL[1]]
    assert inside and all(p["chi2"] is None and "simulation failed" in p["error"] for p in inside)
    assert all("error" not in p for p in k["profile"] if not K_FAIL[0] < p["value"] < K_FAIL[1])
    assert beyond and all(p["chi2"] > 0 for p in beyond)  # walked on past the failed points
    assert k["estimate"] == pytest.approx(MSD_TRUTH["k"], rel=0.02)
    assert k["ci"]["simultaneous"][1] > K_FAIL[1]  # crossed among the points after the band
    assert_next_job_succeeds(client, step_csv)


def test_unbounded_allocation_fails_only_its_job(service_factory, test_fmus, step_csv):
    service = service_factory(FMUID_JOB_MEMORY_MB=str(MEMORY_MB))
    client = service.client()
    job = client.submit("fit", msd_spec(), [step_csv], fmu_path=test_fmus["leak_step"])
    status = client.wait(job, timeout=300)
    assert status["status"] == "failed"
    assert status["error"].startswith(
        f"exceeded the memory limit of {MEMORY_MB} MB (FMUID_JOB_MEMORY_MB): the FMU gave up"
    )
    assert "fmi2DoStep" in status["error"]
    assert client.health()["status"] == "ok"
    assert_next_job_succeeds(client, step_csv)


def assert_next_job_succeeds(client, step_csv):
    job = client.submit("fit", msd_spec(), [step_csv], model="msd")
    status = client.wait(job, timeout=300)
    assert status["status"] == "done", status
    assert client.result(job)["parameters"]["k"]["estimate"] == pytest.approx(4.4, rel=0.05)
