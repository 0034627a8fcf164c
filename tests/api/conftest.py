"""Fixtures of the API tests: a real service process on a free loopback port, data, test FMUs."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from api_helpers import Service, msd_csv
from fmuid.model.build import build_fmu
from fmuid.model.builtin import builtin_fmu, model_src_dir

HERE = Path(__file__).parent


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
def msd_file() -> Path:
    return builtin_fmu("msd")


@pytest.fixture(scope="session")
def broken_fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """FMUs built from ``fmus_src/``: the msd interface with misbehaving (or slow) physics."""
    out = tmp_path_factory.mktemp("broken_fmus")
    return {
        d.name: build_fmu(model_src_dir(), d, out)
        for d in sorted((HERE / "fmus_src").iterdir())
        if (d / "variables.json").is_file()
    }
