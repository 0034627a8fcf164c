"""A long ``TMPDIR`` (40 characters) still runs profile jobs, whose process pools need Unix
sockets (at most 107 bytes of path), and a service leaves no folder of its own in it."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pytest

from api_helpers import msd_spec

pytestmark = pytest.mark.slow

LENGTH = 40


@pytest.fixture
def long_tmpdir():
    base = Path(tempfile.mkdtemp(prefix="fmuid-long-", dir="/tmp"))
    path = base.with_name(base.name + "x" * (LENGTH - len(str(base))))
    base.rename(path)
    assert len(str(path)) == LENGTH
    yield path
    shutil.rmtree(path, ignore_errors=True)


def test_a_profile_job_runs_under_a_40_character_tmpdir(
    service_factory, step_csv, tmp_path, long_tmpdir
):
    service = service_factory(tmp_path / "data", TMPDIR=str(long_tmpdir))
    client = service.client()
    job = client.submit("profile", msd_spec(), [step_csv], model="msd")
    status = client.wait(job, timeout=600)
    assert status["status"] == "done", status
    assert client.health()["status"] == "ok"
    service.stop()
    assert not list(long_tmpdir.iterdir())
