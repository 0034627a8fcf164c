"""The engines give the same results, events and counts: in this process and in two workers;
a pool's workers learn the owner's verdict on the FMU's reset at every run."""

import os
import shutil
from dataclasses import dataclass

import pytest

from fmuid.engine.count import counted, counting
from fmuid.engine.run import open_engine
from fmuid.model.fmu import FmuModel
from fmuid.model.registry import mark_reset_unreliable, registry


@dataclass(frozen=True)
class Countdown:
    """Reports ``n - 1, ..., 0`` and counts ``n`` simulations; returns ``n`` squared and its pid."""

    n: int

    def execute(self, report):
        for k in reversed(range(self.n)):
            report(k)
        counted(self.n)
        return self.n**2, os.getpid()


def _run(model, workers):
    tasks = [Countdown(n) for n in (3, 0, 5, 1)]
    events, done = {}, []

    def on_done(k, result):
        assert k not in done and events.get(k, [0])[-1] == 0  # after all its events
        done.append(k)

    with open_engine(model, workers=workers, at_most=len(tasks)) as engine, counting() as count:
        results = engine.run(
            tasks, on_done=on_done, on_event=lambda k, e: events.setdefault(k, []).append(e)
        )
        mapped = engine.map(pow, [2, 3], [5, 2])
    return results, events, sorted(done), mapped, count.simulations


def test_two_workers_give_the_serial_results_events_and_order(msd_fmu):
    model = FmuModel(msd_fmu)
    here, events, done, mapped, sims = _run(model, 1)
    pooled, pooled_events, pooled_done, pooled_mapped, pooled_sims = _run(model, 2)
    assert [r[0] for r in here] == [r[0] for r in pooled] == [9, 0, 25, 1]
    assert {pid for _, pid in here} == {os.getpid()}
    assert os.getpid() not in {pid for _, pid in pooled}
    assert events == pooled_events == {0: [2, 1, 0], 2: [4, 3, 2, 1, 0], 3: [0]}
    assert done == pooled_done == [0, 1, 2, 3]
    assert mapped == pooled_mapped == [32, 9]
    assert sims == pooled_sims == 3 + 0 + 5 + 1


def test_counts_nest_and_a_task_counts_apart():
    with counting() as outer:
        counted(2)
        with counting() as inner:
            counted(3)
        with counting(apart=True) as apart:
            counted(5)
    counted(7)
    assert (outer.simulations, inner.simulations, apart.simulations) == (5, 3, 5)


def _stopped(model, **engine):
    tasks = [Countdown(n) for n in (3, 0, 5, 1, 4, 2)]
    asked, events = [], {}

    def until(k, result):
        asked.append(k)
        return result[0] == 25  # the third task

    with open_engine(model, at_most=len(tasks), **engine) as run, counting() as count:
        results = run.run(
            tasks, until=until, on_event=lambda k, e: events.setdefault(k, []).append(e)
        )
    return [r[0] for r in results], asked, events, count.simulations


@pytest.mark.slow
def test_a_run_stops_at_the_first_task_in_order_whose_result_says_so(msd_fmu):
    """The same task stops the run in this process, two workers and dask."""
    from distributed import Client, LocalCluster

    model = FmuModel(msd_fmu)
    here, asked, events, sims = _stopped(model, workers=1)
    assert here == [9, 0, 25] and asked == [0, 1, 2]
    assert set(events) == {0, 2} and sims == 3 + 0 + 5  # the later tasks never ran
    pooled, pooled_asked, _, _ = _stopped(model, workers=2)
    assert pooled == here and pooled_asked == asked
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as cluster,
        Client(cluster) as client,
    ):
        remote, remote_asked, _, _ = _stopped(model, executor=client)
    assert remote == here and remote_asked == asked


@dataclass(frozen=True)
class ResetVerdict:
    """Returns whether this process takes the FMU's reset as unreliable."""

    model: FmuModel

    def execute(self, report):
        return registry().reset_unreliable(self.model.key)


def test_a_pool_learns_a_reset_verdict_made_after_it_started(msd_fmu, tmp_path):
    copy = tmp_path / msd_fmu.name  # its own key: this process's verdict on msd stays as it is
    shutil.copy(msd_fmu, copy)
    model = FmuModel(copy)
    tasks = [ResetVerdict(model)] * 2
    with open_engine(model, workers=2, at_most=2) as engine:
        before = engine.run(tasks)
        mark_reset_unreliable(model)  # as a health check does between a diagnosis's stages
        after = engine.run(tasks)
    assert before == [False, False]
    assert after == [True, True]
