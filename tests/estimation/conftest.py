"""Fixtures of the estimation tests: an FMU whose initial states are parameters."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def two_tanks_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``tests/pythonfmu_src/two_tanks.py`` built by pythonfmu: initial levels as parameters."""
    pythonfmu = pytest.importorskip(
        "pythonfmu", reason="pythonfmu is not installed (pip install -e '.[dev]')"
    )
    if not pythonfmu.FmuBuilder.has_binary():
        pytest.skip("pythonfmu ships no FMU binary for this platform")
    source = Path(__file__).parents[1] / "pythonfmu_src" / "two_tanks.py"
    out = tmp_path_factory.mktemp("two_tanks")
    return Path(pythonfmu.FmuBuilder.build_FMU(source, dest=out))
