"""Load test of the service: many small jobs, status latency under heavy jobs and big uploads.

Starts ``python -m fmuid.api`` on a free loopback port with a fresh data folder, then

1. submits N small ``fit`` jobs (built-in ``msd`` model, trust-region only) from N threads at
   once, polls ``GET /v1/jobs/{id}`` and ``/v1/health`` until all finish: jobs/min, p50/p99
   status latency, the deepest queue seen and worker utilisation (job-process busy time over
   workers x wall time);
2. submits 2 heavy jobs (``msd`` profiles with a global search) and polls their status for
   ``--heavy-s`` seconds while they run: p50/p99/max status latency, then cancels them;
3. posts ``--uploads`` bodies of 45 MB (refused: they are no FMU) while health is polled:
   p99/max health latency during the uploads;
4. asks for the report of every small job at once (each one's first request: a drawing each)
   while status is polled: p50/p99/max status latency, the answers and how long all took.

The load of the machine (``/proc/loadavg``) before and after is printed with the table.

    python bench/load.py [--jobs 50] [--workers 2] [--heavy-s 20] [--uploads 3]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from datetime import datetime
from pathlib import Path
from typing import Any

import httpx
import numpy as np
from scipy.integrate import solve_ivp

SPEC = json.dumps(
    {
        "parameters": {
            n: {"start": v, "lower": 0.01, "upper": 10.0}
            for n, v in {"m": 1.1, "k": 4.4, "b": 1.6}.items()
        },
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.2}},
        "global_search": False,
    }
)


def write_csv(path: Path, end: float = 10.0, step: float = 0.2) -> None:
    t = np.arange(0.0, end + 1e-9, step)
    sol = solve_ivp(
        lambda _t, y: [y[1], (40.0 - 1.6 * y[1] - 4.4 * y[0]) / 1.1],
        (0.0, end),
        [0.0, 0.0],
        t_eval=t,
        rtol=1e-10,
    )
    x = sol.y[0] + np.random.default_rng(0).normal(0.0, 0.2, t.size)
    path.write_text("time,f,x\n" + "".join(f"{a:.6g},40,{b:.9g}\n" for a, b in zip(t, x)))


def start_service(data_dir: Path, workers: int) -> tuple[subprocess.Popen[bytes], str]:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "FMUID_DATA_DIR": str(data_dir), "FMUID_WORKERS": str(workers)}
    log = open(data_dir / "service.log", "wb")  # noqa: SIM115
    proc = subprocess.Popen(
        [sys.executable, "-m", "fmuid.api", "--port", str(port)], env=env, stdout=log, stderr=log
    )
    url = f"http://127.0.0.1:{port}"
    for _ in range(300):
        try:
            httpx.get(url + "/v1/health", timeout=1).raise_for_status()
            return proc, url
        except httpx.HTTPError:
            time.sleep(0.1)
    raise RuntimeError("service did not start")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--jobs", type=int, default=50)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--heavy-s", type=float, default=20.0)
    parser.add_argument("--uploads", type=int, default=3)
    args = parser.parse_args()
    load_before = Path("/proc/loadavg").read_text().split()[:3]
    with tempfile.TemporaryDirectory(prefix="fmuid-bench-") as tmp:
        data_dir = Path(tmp)
        csv = data_dir / "step.csv"
        write_csv(csv)
        proc, url = start_service(data_dir, args.workers)
        try:
            rows, ids = small_jobs(url, csv, args.jobs, args.workers)
            rows += heavy_jobs(url, csv, args.heavy_s)
            rows += uploads(url, csv, args.uploads)
            rows += first_reports(url, ids)
        finally:
            proc.terminate()
            proc.wait()
    rows.append(("load average before / after", f"{load_before} / {_load()}"))
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")


def _load() -> list[str]:
    return Path("/proc/loadavg").read_text().split()[:3]


class Poller:
    """Poll ``path`` (a callable giving it) every 10 ms in a thread; keep each answer's time."""

    def __init__(self, url: str, path: Any):
        self.url = url
        self.path = path
        self.latencies: list[float] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll)

    def _poll(self) -> None:
        with httpx.Client(base_url=self.url, timeout=30) as client:
            i = 0
            while not self._stop.is_set():
                start = time.perf_counter()
                client.get(self.path(i)).raise_for_status()
                self.latencies.append(time.perf_counter() - start)
                i += 1
                time.sleep(0.01)

    def __enter__(self) -> Poller:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def row(self, what: str) -> tuple[str, str]:
        lat = np.array(self.latencies) * 1000
        p50, p99 = np.percentile(lat, [50, 99])
        return (f"{what} p50 / p99 / max [ms]", f"{p50:.1f} / {p99:.1f} / {lat.max():.1f}")


def heavy_jobs(url: str, csv: Path, seconds: float) -> list[tuple[str, str]]:
    """Status latency while 2 profile jobs with a global search on 4000 samples run."""
    spec = json.loads(SPEC)
    spec["global_search"] = True
    csv = csv.with_name("long.csv")
    write_csv(csv, end=80.0, step=0.02)
    with httpx.Client(base_url=url, timeout=120) as client:
        ids = []
        for _ in range(2):
            r = client.post(
                "/v1/jobs",
                data={"kind": "profile", "spec": json.dumps(spec), "model": "msd"},
                files=[("data", ("step.csv", csv.read_bytes(), "text/csv"))],
            )
            ids.append(r.raise_for_status().json()["id"])
        while client.get("/v1/health").json()["running"] < 2:
            time.sleep(0.05)
        with Poller(url, lambda i: f"/v1/jobs/{ids[i % 2]}") as poller:
            time.sleep(seconds)
        running = [client.get(f"/v1/jobs/{job}").json()["status"] for job in ids]
        for job in ids:
            client.delete(f"/v1/jobs/{job}")
    return [
        poller.row(f"status latency, 2 heavy jobs running {seconds:g} s,"),
        ("heavy jobs running at the end (then cancelled)", f"{running.count('running')} of 2"),
    ]


def uploads(url: str, csv: Path, n: int) -> list[tuple[str, str]]:
    """Health latency while ``n`` bodies of 45 MB are posted one after another."""
    blob = np.random.default_rng(0).bytes(45 * 1024 * 1024)
    statuses = []
    with Poller(url, lambda _: "/v1/health") as poller, httpx.Client(timeout=300) as client:
        for _ in range(n):
            r = client.post(
                f"{url}/v1/jobs",
                data={"kind": "fit", "spec": SPEC},
                files=[
                    ("fmu", ("big.fmu", blob, "application/octet-stream")),
                    ("data", ("step.csv", csv.read_bytes(), "text/csv")),
                ],
            )
            statuses.append(r.status_code)
    return [
        poller.row(f"health latency, {n} uploads of 45 MB,"),
        ("upload answers", " ".join(map(str, statuses))),
    ]


def first_reports(url: str, ids: list[str]) -> list[tuple[str, str]]:
    """Status latency while the first report of every job in ``ids`` is asked for at once."""

    def report(job: str) -> int:
        return httpx.get(f"{url}/v1/jobs/{job}/report", timeout=900).status_code

    t0 = time.monotonic()
    with Poller(url, lambda i: f"/v1/jobs/{ids[i % len(ids)]}") as poller:
        with ThreadPoolExecutor(len(ids)) as pool:
            codes = list(pool.map(report, ids))
    wall = time.monotonic() - t0
    answers = " ".join(f"{code} x{codes.count(code)}" for code in sorted(set(codes)))
    return [
        poller.row(f"status latency, {len(ids)} first report requests,"),
        ("report answers / time for all [s]", f"{answers} / {wall:.1f}"),
    ]


def small_jobs(
    url: str, csv: Path, n_jobs: int, workers: int
) -> tuple[list[tuple[str, str]], list[str]]:
    content = csv.read_bytes()

    def submit(_: int) -> str:
        with httpx.Client(base_url=url, timeout=120) as client:
            r = client.post(
                "/v1/jobs",
                data={"kind": "fit", "spec": SPEC, "model": "msd"},
                files=[("data", ("step.csv", content, "text/csv"))],
            )
            if r.status_code != 202:
                raise RuntimeError(f"submission answered {r.status_code}: {r.text}")
            return str(r.json()["id"])

    t0 = time.monotonic()
    with ThreadPoolExecutor(n_jobs) as pool:
        ids = list(pool.map(submit, range(n_jobs)))
    submitted = time.monotonic() - t0

    latencies: list[float] = []
    depth = 0
    done = threading.Event()

    def poll() -> None:
        nonlocal depth
        with httpx.Client(base_url=url, timeout=30) as client:
            i = 0
            while not done.is_set():
                job = ids[i % len(ids)]
                start = time.perf_counter()
                client.get(f"/v1/jobs/{job}").raise_for_status()
                latencies.append(time.perf_counter() - start)
                if i % 20 == 0:
                    health = client.get("/v1/health").json()
                    depth = max(depth, health["queued"])
                    if health["queued"] == 0 and health["running"] == 0:
                        done.set()
                i += 1
                time.sleep(0.01)

    poller = threading.Thread(target=poll)
    poller.start()
    poller.join()
    wall = time.monotonic() - t0
    final = [httpx.get(f"{url}/v1/jobs/{job}").json() for job in ids]
    busy = sum(
        (
            datetime.fromisoformat(s["finished"]) - datetime.fromisoformat(s["started"])
        ).total_seconds()
        for s in final
        if s["started"] and s["finished"]
    )
    ok = sum(s["status"] == "done" for s in final)
    lat = np.array(latencies) * 1000
    rows = [
        ("jobs submitted / done", f"{n_jobs} / {ok}"),
        ("submission of all jobs [s]", f"{submitted:.1f}"),
        ("wall time [s]", f"{wall:.1f}"),
        ("jobs/min", f"{ok / wall * 60:.1f}"),
        ("status requests", f"{lat.size}"),
        ("status latency p50 [ms]", f"{np.percentile(lat, 50):.1f}"),
        ("status latency p99 [ms]", f"{np.percentile(lat, 99):.1f}"),
        ("max queue depth seen", f"{depth}"),
        ("workers", f"{workers}"),
        ("worker utilisation", f"{busy / (workers * wall):.0%}"),
    ]
    return rows, [s["id"] for s in final if s["status"] == "done"]


if __name__ == "__main__":
    main()
