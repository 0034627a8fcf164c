"""Hostile uploads for the service: their generators, a service on a free port, a health watch.

Each attack is a submission (spec, CSV, FMU) that once cost the service too much: a
backtracking-bait number cell, a 20k-column header, a spec with 20k keys, a deeply nested spec,
an FMU with a corrupt zip entry, an FMU whose modelDescription lists a million variables.
:class:`HealthWatch` polls ``GET /v1/health`` every 10 ms while one is open. Used by
``bench/input_attacks.py`` and ``tests/hardening/test_input_attacks.py``.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import socket
import subprocess
import sys
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import httpx

MSD_SPEC = {
    "parameters": {
        n: {"start": v, "lower": 0.01, "upper": 10.0}
        for n, v in {"m": 1.1, "k": 4.4, "b": 1.6}.items()
    },
    "inputs": ["f"],
    "outputs": {"x": {"sigma": 0.2}},
    "global_search": False,
}
GOOD_CSV = b"time,f,x\n0,40,0\n0.2,40,0.1\n0.4,40,0.3\n"


def redos_csv(digits: int) -> bytes:
    """A CSV whose one cell is ``digits`` digits then a letter (bait for a backtracking regex)."""
    return b"time,f,x\n0,40,0\n0.2,40," + b"1" * digits + b"x\n"


def wide_csv(columns: int) -> bytes:
    """A CSV with ``columns`` extra columns nobody asked for."""
    extra = ",".join(f"c{i}" for i in range(columns)).encode()
    zeros = b",0" * columns
    return b"time,f,x," + extra + b"\n0,40,0" + zeros + b"\n0.2,40,0.1" + zeros + b"\n"


def many_keys_spec(keys: int) -> str:
    """The msd spec with ``keys`` extra fixed parameters."""
    return json.dumps({**MSD_SPEC, "fixed": {f"p{i}": 1.0 for i in range(keys)}})


def deep_spec(depth: int) -> str:
    """The msd spec with a list nested ``depth`` deep under ``inputs``."""
    spec = json.dumps(MSD_SPEC)
    return spec.replace('["f"]', "[" * depth + "]" * depth)


def big_model_description(msd: Path, target: Path, variables: int) -> Path:
    """The msd FMU with ``variables`` extra parameters appended to its modelDescription."""
    with zipfile.ZipFile(msd) as src:
        xml = src.read("modelDescription.xml").decode()
        members = {info.filename: src.read(info) for info in src.infolist()}
    extra = "".join(
        f'<ScalarVariable name="p{i}" valueReference="{100 + i}" causality="parameter" '
        f'variability="tunable"><Real start="1.0"/></ScalarVariable>\n'
        for i in range(variables)
    )
    members["modelDescription.xml"] = xml.replace(
        "</ModelVariables>", extra + "</ModelVariables>"
    ).encode()
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as dst:
        for name, content in members.items():
            dst.writestr(name, content)
    return target


def corrupt_member(msd: Path, target: Path, member: str = "modelDescription.xml") -> Path:
    """The msd FMU with the compressed bytes of one member overwritten (its CRC no longer holds)."""
    data = bytearray(msd.read_bytes())
    with zipfile.ZipFile(msd) as zf:
        info = zf.getinfo(member)
    start = info.header_offset + 30 + len(info.filename.encode()) + len(info.extra)
    for i in range(start + 10, start + min(info.compress_size, 60)):
        data[i] ^= 0x5A
    target.write_bytes(bytes(data))
    return target


def start_service(data_dir: Path, **env: str) -> tuple[subprocess.Popen[bytes], str]:
    """Start ``python -m fmuid.api`` on a free port; return the process and its base URL."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    log = open(data_dir / "service.log", "wb")  # noqa: SIM115
    proc = subprocess.Popen(
        [sys.executable, "-m", "fmuid.api", "--port", str(port)],
        env={**os.environ, "FMUID_DATA_DIR": str(data_dir), **env},
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(url + "/v1/health", timeout=1.0).status_code == 200:
                return proc, url
        except httpx.TransportError:
            time.sleep(0.1)
    proc.kill()
    raise RuntimeError("service did not start")


def _poll_health(url: str, period: float, started: Any, stop: Any, results: Any) -> None:
    """Poll health until ``stop`` is set; put the slowest answer's time, the failures and the
    poller's latest wake-up.

    ``started`` is set after the first answer, so that the watch covers the whole attack.
    """
    worst = late = 0.0
    failures: list[str] = []
    with httpx.Client(timeout=30) as client:
        while not stop.is_set():
            start = time.perf_counter()
            try:
                status = client.get(url + "/v1/health").status_code
                if status != 200:
                    failures.append(f"health answered {status}")
            except httpx.TransportError as exc:
                failures.append(f"health failed: {exc!r}")
            worst = max(worst, time.perf_counter() - start)
            started.set()
            asleep = time.perf_counter()
            stop.wait(period)
            late = max(late, time.perf_counter() - asleep - period)
    results.put((worst, failures, late))


class HealthWatch:
    """Poll ``/v1/health`` every ``period`` seconds from a process of its own.

    The poller lives outside the process that posts the attack, so that whatever that process
    does (building a large upload) does not delay the measurement. ``worst`` is the slowest
    answer [s]; ``failures`` lists answers other than 200; ``late`` is the longest the poller
    woke past its period [s], a measure of how busy the machine's cores were meanwhile.
    """

    def __init__(self, url: str, period: float = 0.01):
        context = multiprocessing.get_context("spawn")
        self._started = context.Event()
        self._stop = context.Event()
        self._results: Any = context.Queue()
        self._process = context.Process(
            target=_poll_health,
            args=(url, period, self._started, self._stop, self._results),
            daemon=True,
        )
        self.worst = self.late = 0.0
        self.failures: list[str] = []

    def __enter__(self) -> HealthWatch:
        self._process.start()
        if not self._started.wait(60):
            raise RuntimeError("the health poller did not get a first answer within 60 s")
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self.worst, self.failures, self.late = self._results.get(timeout=60)
        self._process.join()


def post_job(
    url: str, spec: str, csv: bytes, fmu: Path | None = None, timeout: float = 600
) -> httpx.Response:
    """Submit a profile job of msd (built-in unless ``fmu`` is given)."""
    form = {"kind": "profile", "spec": spec}
    files: list[tuple[str, tuple[str, bytes]]] = [("data", ("step.csv", csv))]
    if fmu is None:
        form["model"] = "msd"
    else:
        files.append(("fmu", (fmu.name, fmu.read_bytes())))
    return httpx.post(url + "/v1/jobs", data=form, files=files, timeout=timeout)


Attack = tuple[str, bytes, Path | None]
"""A submission: spec text, CSV content, FMU file (None: the built-in msd)."""


def make_attack(name: str, msd: Path, workdir: Path, variables: int) -> Attack:
    """Build the inputs of one attack by name (before the clock starts)."""
    spec = json.dumps(MSD_SPEC)
    makers: dict[str, Callable[[], Attack]] = {
        "redos-1000": lambda: (spec, redos_csv(1000), None),
        "redos-8000": lambda: (spec, redos_csv(8000), None),
        "columns-20k": lambda: (spec, wide_csv(20_000), None),
        "keys-20k": lambda: (many_keys_spec(20_000), GOOD_CSV, None),
        "nesting-100k": lambda: (deep_spec(100_000), GOOD_CSV, None),
        "corrupt-zip": lambda: (spec, GOOD_CSV, corrupt_member(msd, workdir / "corrupt.fmu")),
        "fmu-1M": lambda: (
            spec,
            GOOD_CSV,
            big_model_description(msd, workdir / "big.fmu", variables),
        ),
    }
    return makers[name]()


ATTACKS = (
    "redos-1000",
    "redos-8000",
    "columns-20k",
    "keys-20k",
    "nesting-100k",
    "corrupt-zip",
    "fmu-1M",
)
