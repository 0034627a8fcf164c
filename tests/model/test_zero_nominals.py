"""Model exchange of an FMU whose state nominals are 0 and negative (Dymola's are 0), checked
against scipy; a CVode failure is one clear message, without SUNDIALS' lines on stderr."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from tests.model.quirks import build_framework_fmu

from fmuid.errors import FmuError
from fmuid.model.simulator import Simulator

TIMES = np.linspace(0.0, 4.0, 17)
SPAN = np.array([0.0, 4.0])


@pytest.fixture(scope="module")
def zero_nominals_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_framework_fmu("zero_nominals", tmp_path_factory.mktemp("zero_nominals"))


def oscillator(k: float, c: float) -> np.ndarray:
    """x and v of x'' = -k x - c x', x(0) = 1, v(0) = 0, by solve_ivp."""
    sol = solve_ivp(
        lambda t, y: [y[1], -k * y[0] - c * y[1]],
        (0.0, 4.0),
        [1.0, 0.0],
        t_eval=TIMES,
        rtol=1e-11,
        atol=1e-13,
    )
    return sol.y.T


def test_invalid_nominals_are_replaced_and_said_once(
    zero_nominals_fmu: Path, caplog: pytest.LogCaptureFixture
) -> None:
    sim = Simulator(zero_nominals_fmu)
    try:
        with caplog.at_level(logging.WARNING, logger="fmuid.model.exchange"):
            runs = [
                sim.simulate({"k": k, "c": 0.3}, SPAN, {}, TIMES, ["x", "v"]) for k in (2.0, 6.0)
            ]
    finally:
        sim.close()
    for run, k in zip(runs, (2.0, 6.0), strict=True):
        np.testing.assert_allclose(run, oscillator(k, 0.3), atol=2e-6)
    said = [r.getMessage() for r in caplog.records if "invalid nominals" in r.getMessage()]
    assert len(said) == 1 and "[-2.0, 0.0]" in said[0]


def test_a_cvode_failure_is_one_message(
    zero_nominals_fmu: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    sim = Simulator(zero_nominals_fmu)
    try:
        with pytest.raises(
            FmuError,
            match=r"model-exchange solver \(SUNDIALS CVode.*\) failed "
            r"between t = 0.0 s and 0.25 s: At t = .*corrector",
        ):
            sim.simulate({"k": 2.0, "c": -1e4}, SPAN, {}, TIMES, ["x"])
    finally:
        sim.close()
    err = capfd.readouterr().err
    assert "[ERROR]" not in err and "[WARNING]" not in err
