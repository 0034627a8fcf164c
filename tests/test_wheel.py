"""The built wheel with the service extra, in a fresh venv, works outside the repository.

Slow: pip builds the wheel and installs the pinned dependencies (constraints.txt) from PyPI or
pip's cache into a new virtual environment.
"""

import os
import signal
import socket
import subprocess
import sys
import time
import venv
from pathlib import Path

import httpx
import pytest

from msd_study import write_msd_study

REPO = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _clean_env() -> dict[str, str]:
    """The environment without fmuid settings and PYTHONPATH (which would show the source tree)."""
    return {k: v for k, v in os.environ.items() if not k.startswith(("FMUID_", "PYTHON"))}


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A fresh venv holding the wheel with the service extra; returns its bin folder."""
    root = tmp_path_factory.mktemp("wheel")
    env = _clean_env()
    dist = root / "dist"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", dist, REPO],
        check=True,
        timeout=600,
        env=env,
    )
    (wheel,) = dist.glob("fmuid-*.whl")
    venv.create(root / "venv", with_pip=True)
    bin_dir = root / "venv" / "bin"
    subprocess.run(
        [bin_dir / "python", "-m", "pip", "install", "-q", "-c", REPO / "constraints.txt"]
        + [f"{wheel}[service]"],
        check=True,
        timeout=1500,
        env=env,
    )
    return bin_dir


def _env(tmp_path: Path) -> dict[str, str]:
    return {
        **_clean_env(),
        "XDG_CACHE_HOME": str(tmp_path / "cache"),
        "XDG_DATA_HOME": str(tmp_path),
    }


def test_installed_wheel_runs_info_fit_and_serve(installed, tmp_path):
    env = _env(tmp_path)
    write_msd_study(tmp_path)

    def fmuid(*args: str) -> str:
        done = subprocess.run(
            [installed / "fmuid", *args],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr
        return done.stdout

    assert fmuid("--version").strip() == "fmuid 0.1.0"
    text = fmuid("info", "msd")
    assert "N/m" in text and "Spring stiffness" in text
    # the built-in FMUs were compiled from the package's sources into the user cache
    cached = list((tmp_path / "cache" / "fmuid" / "fmus").glob("*/msd.fmu"))
    assert len(cached) == 1
    assert str(cached[0]) in fmuid("info", "msd", "--json")
    assert not (tmp_path / "fmus").exists()

    fmuid(
        "fit",
        "--fmu",
        "msd",
        "--data",
        "step.csv",
        "--spec",
        "spec.json",
        "--out",
        "fit.json",
        "--report",
        "report",
    )
    assert "k" in (tmp_path / "fit.json").read_text()
    assert "Verdict" in (tmp_path / "report" / "index.html").read_text()  # templates shipped

    port = _free_port()
    server = subprocess.Popen(
        [installed / "fmuid", "serve", "--port", str(port)],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                health = httpx.get(f"http://127.0.0.1:{port}/v1/health", timeout=2)
                break
            except httpx.TransportError:
                assert server.poll() is None, server.stderr.read().decode() if server.stderr else ""
                assert time.monotonic() < deadline, "fmuid serve did not answer"
                time.sleep(0.5)
        assert health.status_code == 200
        assert health.json()["status"] == "ok"
    finally:
        server.send_signal(signal.SIGINT)
        server.wait(timeout=30)
