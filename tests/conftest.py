"""Session fixtures shared by all tests: the built-in FMUs, compiled once per session."""

from __future__ import annotations

import functools
import json
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

from fmuid.model.build import build_fmu, build_fmus
from fmuid.model.builtin import model_src_dir

#: Property tests draw the same examples on every run and machine, so that CI gives one verdict:
#: Hypothesis's "ci" profile (derandomized, no example database, no deadline), loaded here even
#: where the CI variable is not set. Settings objects made in test modules inherit it.
settings.load_profile("ci")

SERVICE_FIXTURES = {"service", "service_factory"}
"""Fixtures that start the real service (uvicorn in its own process): a test using one is slow.
The fast run covers the routes in-process (``tests/api/test_in_process.py``)."""


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark every test that starts the real service ``slow``, before ``-m`` selects."""
    for item in items:
        if SERVICE_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session", autouse=True)
def results_match_their_schema() -> Iterator[None]:
    """Check every result JSON this test process writes against its kind's one schema.

    Each result class's ``to_dict`` is wrapped to validate its output with
    ``fmuid.results.schema.KINDS[kind]`` strictly: a field the schema does not name (at any
    depth), or does not type as written (the schema's dump of it differs), fails the test that
    wrote it.
    """
    from fmuid.discrepancy.result import Diagnosis
    from fmuid.estimation.result import FitResult
    from fmuid.experiment_design.result import DesignResult
    from fmuid.profiling.result import ProfileResult

    with pytest.MonkeyPatch.context() as patch:
        for cls in (FitResult, ProfileResult, Diagnosis, DesignResult):
            patch.setattr(cls, "to_dict", _validated(cls.to_dict))
        yield


def _validated(to_dict: Callable[..., dict[str, Any]]) -> Callable[..., dict[str, Any]]:
    from fmuid.results.schema import KINDS

    @functools.wraps(to_dict)
    def checked(self: Any, *args: Any, **kwargs: Any) -> dict[str, Any]:
        out = to_dict(self, *args, **kwargs)
        again = KINDS[out["kind"]].model_validate(out).model_dump(mode="json", exclude_unset=True)
        assert json.dumps(again) == json.dumps(out), f"{out['kind']} JSON is not its schema's"
        return out

    return checked


SLOW_LINE_S = float(os.environ.get("FMUID_SLOW_LINE_S", "2"))
"""Seconds of a test's call past which it must be marked ``slow`` (the project's ~2 s line)."""

_unmarked_slow: list[tuple[float, str]] = []


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Record each unmarked test whose call (fixture set-up excluded) took over the slow line."""
    if report.when == "call" and "slow" not in report.keywords and report.duration > SLOW_LINE_S:
        _unmarked_slow.append((report.duration, report.nodeid))


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """List the unmarked tests over the slow line: a printed check, never a failure.

    Timings vary with the machine's load, so the run does not fail on them; the load average is
    printed so that a reader can tell a slow test from a busy machine.
    """
    if not _unmarked_slow:
        return
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    terminalreporter.section(f"unmarked tests over {SLOW_LINE_S:g} s (mark them slow)")
    terminalreporter.line(f"load average {load} on {os.cpu_count()} CPUs")
    for seconds, nodeid in sorted(_unmarked_slow, reverse=True):
        terminalreporter.line(f"{seconds:7.2f} s  {nodeid}")


@pytest.fixture(scope="session")
def built_fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Build every model in ``model_src/`` into a temporary folder; model name -> ``.fmu``."""
    out_dir = tmp_path_factory.mktemp("fmus")
    return {path.stem: path for path in build_fmus(model_src_dir(), out_dir)}


@pytest.fixture(scope="session")
def tractor_fmu(built_fmus: dict[str, Path]) -> Path:
    return built_fmus["tractor_implement"]


@pytest.fixture(scope="session")
def msd_fmu(built_fmus: dict[str, Path]) -> Path:
    return built_fmus["msd"]


@pytest.fixture(scope="session")
def msd_parallel_fmu(built_fmus: dict[str, Path]) -> Path:
    return built_fmus["msd_parallel"]


def build_pythonfmu(tmp_path_factory: pytest.TempPathFactory, name: str) -> Path:
    """Build ``tests/pythonfmu_src/<name>.py`` with pythonfmu (skip where it cannot be built)."""
    pythonfmu = pytest.importorskip(
        "pythonfmu", reason="pythonfmu is not installed (pip install -e '.[dev]')"
    )
    if not pythonfmu.FmuBuilder.has_binary():
        pytest.skip("pythonfmu ships no FMU binary for this platform")
    source = Path(__file__).parent / "pythonfmu_src" / f"{name}.py"
    return Path(pythonfmu.FmuBuilder.build_FMU(source, dest=tmp_path_factory.mktemp(name)))


@pytest.fixture(scope="session")
def first_order_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``tests/pythonfmu_src/first_order.py`` built by pythonfmu: a second FMI 2.0 exporter."""
    return build_pythonfmu(tmp_path_factory, "first_order")


@pytest.fixture(scope="session")
def two_tanks_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``tests/pythonfmu_src/two_tanks.py`` built by pythonfmu: initial levels as parameters."""
    return build_pythonfmu(tmp_path_factory, "two_tanks")


@pytest.fixture(scope="session")
def leaky_reset_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``tests/model/fmus_src/leaky_reset``: msd physics whose reset keeps a growing offset."""
    source = Path(__file__).parent / "model" / "fmus_src" / "leaky_reset"
    return build_fmu(model_src_dir(), source, tmp_path_factory.mktemp("leaky"))
