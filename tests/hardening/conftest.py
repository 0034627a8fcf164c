"""Fixtures of the hardening tests: services on free loopback ports, msd data, misbehaving FMUs.

The service process, the msd data and the upload helpers are those of the API tests
(``tests/api_helpers.py``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from api_helpers import Service, msd_csv
from attacks import HealthWatch
from fmuid.model.build import build_fmu
from fmuid.model.builtin import builtin_fmu, model_src_dir

HERE = Path(__file__).parent

HEALTH_S = 0.1
"""The documented bound on health's answer during an attack [s]."""
QUIET_S = 0.03
"""Slowest health answer of the idle service on a machine quiet enough for :data:`HEALTH_S`."""
QUIET_LOAD = 1.0
"""Largest load average per core (over the last minute) of a machine quiet enough for it: no
more runnable processes than cores, on average."""
BLOCKED_S = 0.5
"""Health's slowest answer that still shows an unblocked event loop on a loaded machine [s]: an
attack handled on the loop (a regular expression that backtracks, a parse of a huge document)
holds every answer for seconds, while a machine whose cores other test workers fill delays one
answer by up to a few tenths."""


class HealthBound:
    """The bound on health's slowest answer during an attack.

    On a quiet machine (the idle service's slowest answer under :data:`QUIET_S`, the load under
    :data:`QUIET_LOAD` per core) it is the documented :data:`HEALTH_S`. On a loaded one (the
    README's test command fills both cores with test workers), where other processes alone
    delay an answer by a few tenths of a second, it is the larger of :data:`BLOCKED_S` and
    :data:`HEALTH_S` over twice the idle service's slowest answer: it still fails an attack that
    blocks the service. A machine quiet before the attack counts as loaded when it was not
    during it: the health poller woke more than :data:`QUIET_S` late, or the load rose past
    :data:`QUIET_LOAD` (other test workers started meanwhile).
    """

    def __init__(self, idle_worst: float, record: Callable[[str, object], None]):
        self.idle_worst = idle_worst
        load = _load_per_core()
        self.quiet = idle_worst < QUIET_S and load < QUIET_LOAD
        self.limit = HEALTH_S if self.quiet else max(BLOCKED_S, HEALTH_S + 2 * idle_worst)
        self.record = record
        record("idle_health_worst_ms", round(idle_worst * 1000, 1))
        record("load_per_core", round(load, 2))

    def check(self, watch: HealthWatch) -> None:
        """Assert that every poll was answered 200, the slowest within :attr:`limit`."""
        assert not watch.failures, watch.failures
        self.record("attack_health_worst_ms", round(watch.worst * 1000, 1))
        self.record("attack_poller_late_ms", round(watch.late * 1000, 1))
        quiet = self.quiet and watch.late < QUIET_S and _load_per_core() < QUIET_LOAD
        limit = self.limit if quiet else max(self.limit, BLOCKED_S)
        assert watch.worst < limit, (
            f"health took {watch.worst * 1000:.0f} ms under attack, over the bound of"
            f" {limit * 1000:.0f} ms (idle: {self.idle_worst * 1000:.0f} ms,"
            f" poller late by up to {watch.late * 1000:.0f} ms, quiet machine: {quiet})"
        )


def _load_per_core() -> float:
    """The machine's load average over the last minute, per core."""
    return os.getloadavg()[0] / (os.cpu_count() or 1)


@pytest.fixture
def health_bound_of(record_property) -> Callable[[str], HealthBound]:
    """Measure the idle service at ``url`` for 1 s and return the bound of its next attack."""

    def measure(url: str) -> HealthBound:
        with HealthWatch(url) as watch:
            time.sleep(1)
        return HealthBound(watch.worst, record_property)

    return measure


@pytest.fixture
def service_factory(tmp_path: Path) -> Iterator[Callable[..., Service]]:
    """Start services on demand; every one started is stopped at the end of the test."""
    started: list[Service] = []

    def make(data_dir: Path | None = None, **env: str) -> Service:
        service = Service(data_dir or tmp_path / f"service{len(started)}", **env)
        started.append(service)
        return service.start()

    yield make
    for service in started:
        service.stop()


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    """One service (one worker) shared by the tests of a module."""
    svc = Service(tmp_path_factory.mktemp("service")).start()
    yield svc
    svc.stop()


@pytest.fixture(scope="session")
def step_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return msd_csv(tmp_path_factory.mktemp("data") / "step.csv")


@pytest.fixture(scope="session")
def test_fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """FMUs with the msd interface and misbehaving (or slow) physics, from ``fmus_src/`` here and
    in api."""
    out = tmp_path_factory.mktemp("test_fmus")
    sources = [HERE / "fmus_src", HERE.parent / "api" / "fmus_src"]
    return {
        d.name: build_fmu(model_src_dir(), d, out)
        for src in sources
        for d in sorted(src.iterdir())
        if (d / "variables.json").is_file()
    }


@pytest.fixture(scope="session")
def msd_file() -> Path:
    return builtin_fmu("msd")
