"""A design study gives the same result in one process and on two workers, and resumes."""

import pytest

from design_cases import SMALL, Stop, comparable, counting, space_of, stop_after
from fmuid.engine.local import PoolEngine
from fmuid.experiment_design import design


@pytest.mark.slow
def test_two_local_workers_give_the_serial_ranking_and_numbers(serial, msd_spec, monkeypatch):
    pools = []
    run = PoolEngine.run

    def spy(engine, todo, **kwargs):
        pools.append((len(todo), engine.workers))
        return run(engine, todo, **kwargs)

    monkeypatch.setattr(PoolEngine, "run", spy)
    events = []
    pooled = design("msd", msd_spec, space_of(**SMALL), workers=2, progress=events.append)
    assert pools == [(8, 2), (2, 2)]  # the screen and the verification on 2 processes
    assert comparable(pooled.to_dict()) == comparable(serial.to_dict())
    assert pooled.best.verified.widths == serial.best.verified.widths
    screen = [e.done for e in events if e.detail == "Fisher screen"]
    verify = [e.done for e in events if e.detail.startswith("profiles")]
    assert screen == list(range(1, 9)) and verify == [1, 2]


@pytest.mark.slow
def test_a_dask_cluster_of_worker_processes_gives_the_serial_result(serial, msd_spec):
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as client,
    ):
        remote = design("msd", msd_spec, space_of(**SMALL), executor=client)
    assert comparable(remote.to_dict()) == comparable(serial.to_dict())


@pytest.mark.slow
@pytest.mark.parametrize(("k", "stage"), [(3, "screen"), (9, "verify")])
def test_an_interrupted_study_resumes_without_redoing_finished_evaluations(
    serial, msd_spec, tmp_path, monkeypatch, k, stage
):
    calls = counting(monkeypatch)
    with pytest.raises(Stop):
        design("msd", msd_spec, space_of(**SMALL), checkpoint=tmp_path, progress=stop_after(k))
    assert sum(calls.values()) == k
    calls.update(screen=0, verify=0)
    again = design("msd", msd_spec, space_of(**SMALL), checkpoint=tmp_path)
    # 8 screen evaluations, 2 verification draws; the rate-halved trade-off is one more screen
    assert calls == {"screen": 8 - min(k, 8) + 1, "verify": 2 - max(k - 8, 0)}
    assert comparable(again.to_dict()) == comparable(serial.to_dict())
    # a changed input starts afresh: nothing of the first study is taken
    calls.update(screen=0, verify=0)
    design("msd", msd_spec, space_of(**SMALL, seed=1), checkpoint=tmp_path, verify_designs=0)
    assert calls == {"screen": 8 + 1, "verify": 0}
    assert len(list(tmp_path.iterdir())) == 2
