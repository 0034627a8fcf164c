"""Fixtures of the API tests: a real service process on a free loopback port, data, test FMUs."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fmuid.client import FmuidClient
from fmuid.model.build import build_fmu
from fmuid.model.builtin import builtin_fmu, model_src_dir

HERE = Path(__file__).parent
MSD_TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Service:
    """``python -m fmuid.api`` in its own process, with its data in ``data_dir``."""

    def __init__(self, data_dir: Path, **env: str):
        self.data_dir = data_dir
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.env = {**os.environ, "FMUID_DATA_DIR": str(data_dir), **env}
        self.process: subprocess.Popen[bytes] | None = None
        self.log = data_dir / "service.log"

    def start(self, timeout: float = 30.0) -> Service:
        self.data_dir.mkdir(parents=True, exist_ok=True)
        with open(self.log, "ab") as log:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "fmuid.api", "--port", str(self.port)],
                env=self.env,
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                if httpx.get(self.url + "/v1/health", timeout=1.0).status_code == 200:
                    return self
            except httpx.TransportError:
                pass
            if self.process.poll() is not None:
                break
            time.sleep(0.1)
        raise RuntimeError(f"service did not start:\n{self.log.read_text()}")

    def kill(self) -> None:
        """SIGKILL the service (its job processes die with it through PDEATHSIG)."""
        assert self.process is not None
        self.process.send_signal(signal.SIGKILL)
        self.process.wait()

    def stop(self) -> None:
        assert self.process is not None
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.kill()

    def client(self, token: str | None = None) -> FmuidClient:
        return FmuidClient(self.url, token=token or self.env.get("FMUID_API_TOKEN"))


@pytest.fixture
def service_factory(tmp_path: Path) -> Iterator:
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


def msd_csv(path: Path, sigma: float = 0.2, seed: int = 3, force: float = 40.0) -> Path:
    """A 40 N step response of the mass-spring-damper (solved by scipy) with noise, as CSV."""
    t = np.arange(0.0, 10.0 + 1e-9, 0.2)
    m, k, b = MSD_TRUTH.values()
    sol = solve_ivp(
        lambda _t, y: [y[1], (force - b * y[1] - k * y[0]) / m],
        (0.0, 10.0),
        [0.0, 0.0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-12,
    )
    x = sol.y[0] + np.random.default_rng(seed).normal(0.0, sigma, t.size)
    rows = ["time,f,x"] + [f"{ti:.6g},{force:g},{xi:.9g}" for ti, xi in zip(t, x, strict=True)]
    path.write_text("\n".join(rows) + "\n")
    return path


def msd_spec(sigma: float = 0.2, **extra: object) -> str:
    return json.dumps(
        {
            "parameters": {
                n: {"start": v, "lower": 0.01, "upper": 10.0} for n, v in MSD_TRUTH.items()
            },
            "inputs": ["f"],
            "outputs": {"x": {"sigma": sigma}},
            "global_search": False,
            **extra,
        }
    )


@pytest.fixture(scope="session")
def step_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return msd_csv(tmp_path_factory.mktemp("data") / "step.csv")


@pytest.fixture(scope="session")
def msd_file() -> Path:
    return builtin_fmu("msd")


@pytest.fixture(scope="session")
def broken_fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """FMUs built from ``fmus_src/``: the msd interface with misbehaving physics."""
    out = tmp_path_factory.mktemp("broken_fmus")
    return {
        d.name: build_fmu(model_src_dir(), d, out)
        for d in sorted((HERE / "fmus_src").iterdir())
        if (d / "variables.json").is_file()
    }
