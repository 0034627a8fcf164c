"""Fixtures of the hardening tests: services on free loopback ports, msd data, misbehaving FMUs.

The service process, the msd data and the upload helpers are those of the API tests
(``tests/api/api_helpers.py``).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent / "api"))

from api_helpers import Service, msd_csv  # noqa: E402

from fmuid.model.build import build_fmu  # noqa: E402
from fmuid.model.builtin import builtin_fmu, model_src_dir  # noqa: E402


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
    """FMUs with the msd interface and misbehaving physics, from ``fmus_src/`` here and in api."""
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
