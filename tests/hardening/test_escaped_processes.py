"""A process an FMU starts in a session of its own, with an empty environment, still ends with
the upload check, with the job, and with the service (``fmus_src/spawn_step`` starts
``sleep 3517`` so when loaded and during a run)."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from api_helpers import msd_spec, wait_until

pytestmark = pytest.mark.slow

HELPER = b"sleep\x003517\x00"


def helpers() -> set[int]:
    """Pids of live helpers that spawn_step started (found by their command line)."""
    found = set()
    for entry in Path("/proc").iterdir():
        try:
            cmdline = (entry / "cmdline").read_bytes()
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if cmdline == HELPER and state != "Z":
            found.add(int(entry.name))
    return found


@pytest.fixture
def no_helpers_left():
    """Start without helpers; kill any a failed test leaves."""
    for pid in helpers():
        os.kill(pid, signal.SIGKILL)
    yield
    for pid in helpers():
        os.kill(pid, signal.SIGKILL)


def test_an_fmus_detached_helpers_end_with_the_check_the_job_and_the_service(
    service_factory, step_csv, test_fmus, tmp_path, no_helpers_left
):
    service = service_factory(tmp_path / "data")
    client = service.client()
    blocker = client.submit("fit", msd_spec(), [step_csv], fmu_path=test_fmus["hang_step"])
    assert wait_until(lambda: client.status(blocker)["status"] == "running", 60)

    job = client.submit("fit", msd_spec(), [step_csv], fmu_path=test_fmus["spawn_step"])
    assert client.status(job)["status"] == "queued"
    assert not helpers(), "the upload check left the FMU's helper running"

    client.cancel(blocker)
    assert client.wait(job, timeout=300)["status"] == "done"
    assert wait_until(lambda: not helpers(), 10), "the job left the FMU's helpers running"

    profile = client.submit("profile", msd_spec(), [step_csv], fmu_path=test_fmus["spawn_step"])
    assert wait_until(lambda: client.status(profile)["status"] == "running" and helpers(), 120)
    service.kill()
    assert wait_until(lambda: not helpers(), 20), "the service's death left helpers running"
    service.start()
    assert service.client().wait(profile, timeout=600)["status"] == "done"
    assert wait_until(lambda: not helpers(), 10), "the restarted job left helpers running"
