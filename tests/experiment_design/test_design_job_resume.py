"""A design job killed mid-study and queued again by a restarted service resumes its work."""

import json

import pytest

from api_helpers import stored_file
from design_cases import MSD_SPACE, MSD_SPEC, SMALL, Stop, comparable, counting
from fmuid.jobs import housekeeping as hk
from fmuid.jobs import restarts, run
from fmuid.jobs.layout import DataLayout
from fmuid.jobs.store import Dataset, JobStore
from fmuid.model.builtin import builtin_fmu


@pytest.mark.slow
def test_a_design_job_rerun_after_a_restart_redoes_no_finished_evaluation(
    tmp_path, serial, monkeypatch
):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    space = stored_file(store, text=json.dumps({**MSD_SPACE, **SMALL}))
    job = store.create(
        "design",
        json.dumps(MSD_SPEC),
        stored_file(store, builtin_fmu("msd")),
        "msd",
        [Dataset("E.json", space)],
    )
    calls = counting(monkeypatch)
    events = []

    def killed_after_five(self, event):
        events.append(event)
        if len(events) == 5:
            raise Stop  # the service dies: no outcome is recorded

    with monkeypatch.context() as m:
        m.setattr(run.ProgressWriter, "__call__", killed_after_five)
        try:
            run.run_job(store, store.claim_next(), 2000, None)
        except Stop:
            pass
    assert calls["screen"] == 5 and store.get(job.id).status == "running"
    assert DataLayout(tmp_path).checkpoint(job.id).is_dir()
    hk.remove_orphans(store, alive=set())  # what a restart sweeps keeps it
    assert [j.id for j in restarts.recover(store)] == [job.id]
    hk.remove_orphans(store, alive=set())
    calls.update(screen=0, verify=0)
    assert run.run_job(store, store.claim_next(), 2000, None) == 0
    assert store.get(job.id).status == "done"
    assert calls == {"screen": 8 - 5 + 1, "verify": 2}  # + the rate-halved trade-off
    assert not DataLayout(tmp_path).checkpoint(job.id).exists()
    assert comparable(json.loads(store.result(job.id))) == comparable(serial.to_dict())


def test_a_finished_or_removed_job_leaves_no_checkpoint(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    fmu = stored_file(store, text="fmu")
    queued = store.create("design", "{}", fmu, "m", [])
    failed = store.create("design", "{}", fmu, "m", [])
    store.fail(failed.id, "exceeded the time limit of 1 s")
    for job_id in (queued.id, failed.id, "no-such-job"):
        DataLayout(tmp_path).checkpoint(job_id).mkdir(parents=True)
    hk.remove_orphans(store, alive=set())
    assert DataLayout(tmp_path).checkpoint(queued.id).is_dir()
    assert not DataLayout(tmp_path).checkpoint(failed.id).exists()
    assert not DataLayout(tmp_path).checkpoint("no-such-job").exists()
    assert DataLayout(tmp_path).checkpoint(failed.id) in DataLayout(tmp_path).job_files(failed.id)
