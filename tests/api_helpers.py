"""Helpers of the API tests: a service process, msd data and spec, bad uploads."""

from __future__ import annotations

import io
import json
import os
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import httpx
import numpy as np
from scipy.integrate import solve_ivp

from fmuid.client import FmuidClient

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


def rewrite_fmu(
    source: Path,
    target: Path,
    replace: dict[str, bytes | None],
    extra: dict[str, bytes] | None = None,
) -> Path:
    """Copy an FMU, replacing (or with ``None`` dropping) members and adding ``extra`` ones."""
    with zipfile.ZipFile(source) as src, zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            if info.filename in replace:
                if replace[info.filename] is not None:
                    dst.writestr(info.filename, replace[info.filename])
            else:
                dst.writestr(info, src.read(info))
        for name, content in (extra or {}).items():
            dst.writestr(name, content)
    return target


def member(fmu: Path, name: str) -> bytes:
    with zipfile.ZipFile(fmu) as zf:
        return zf.read(name)


def zip_bomb(target: Path, size: int = 300 * 1024 * 1024) -> Path:
    """A zip whose one member unpacks from a few hundred KB to ``size`` bytes of zeros."""
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as zf:
        with zf.open("modelDescription.xml", "w", force_zip64=True) as out:
            chunk = b"\0" * (1 << 20)
            for _ in range(size // len(chunk)):
                out.write(chunk)
    return target


def multipart(
    fields: dict[str, str],
    files: list[tuple[str, str, bytes]],
    boundary: str = "fmuid-test-boundary",
) -> tuple[bytes, str]:
    """Encode a multipart/form-data body by hand (to send it chunked, without Content-Length)."""
    body = io.BytesIO()
    for name, value in fields.items():
        body.write(
            f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"\r\n\r\n'.encode()
        )
        body.write(value.encode() + b"\r\n")
    for name, filename, content in files:
        body.write(
            f'--{boundary}\r\nContent-Disposition: form-data; name="{name}";'
            f' filename="{filename}"\r\nContent-Type: application/octet-stream\r\n\r\n'.encode()
        )
        body.write(content + b"\r\n")
    body.write(f"--{boundary}--\r\n".encode())
    return body.getvalue(), f"multipart/form-data; boundary={boundary}"


def wait_until(predicate, timeout: float = 120.0, period: float = 0.1) -> bool:
    """Poll ``predicate`` every ``period`` seconds; whether it came true within ``timeout``."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(period)
    return False


def wipe_after_schema(db: Path) -> None:
    """Damage a job database: keep its first page (the schema), overwrite every other byte."""
    with sqlite3.connect(db) as conn:
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    size = db.stat().st_size
    with open(db, "r+b") as stream:
        stream.seek(4096)
        stream.write(b"\xa5" * (size - 4096))


def stored_file(store, source: Path | None = None, text: str | None = None) -> str:
    """Put a file (copied from ``source``, or holding ``text``) into a job store; its sha256."""
    path = store.tmp_dir() / "upload"
    path.parent.mkdir(parents=True, exist_ok=True)
    if source is not None:
        shutil.copyfile(source, path)
    else:
        path.write_text(text or "")
    return store.add_file(path)
