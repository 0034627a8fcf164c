"""The search for a test that would settle a tie is a proposal: its failure costs only itself."""

from __future__ import annotations

from typing import Any

import pytest

from fmuid.discrepancy import settle
from fmuid.errors import FmuError


def _fails(*_: Any, **__: Any) -> None:
    raise FmuError("FMU probe: fmi2DoStep returned Error at t = 3 s", function="fmi2DoStep")


def test_a_failed_search_becomes_a_sentence(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(settle, "default_space", _fails)
    tests, reason = settle.settling_or_reason(object(), object(), [object()])  # type: ignore[arg-type]
    assert tests == []
    assert reason == (
        " No test to settle the tie was searched: FMU probe: fmi2DoStep returned Error at t = 3 s."
    )


def test_without_a_tie_nothing_is_searched(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(settle, "default_space", _fails)
    assert settle.settling_or_reason(object(), object(), []) == ([], "")  # type: ignore[arg-type]


def test_an_error_of_the_code_itself_is_not_hidden(monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(*_: Any, **__: Any) -> None:
        raise KeyError("space")

    monkeypatch.setattr(settle, "default_space", broken)
    with pytest.raises(KeyError):
        settle.settling_or_reason(object(), object(), [object()])  # type: ignore[arg-type]
