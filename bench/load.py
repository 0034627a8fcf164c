"""Load test of the service: many small jobs at once, status latency while workers are busy.

Starts ``python -m fmuid.api`` on a free loopback port with a fresh data folder, submits N small
``fit`` jobs (built-in ``msd`` model, trust-region only) from N threads at once, polls
``GET /v1/jobs/{id}`` and ``/v1/health`` until all finish, and prints a table: jobs/min, p50/p99
status latency, the deepest queue seen and worker utilisation (job-process busy time over
workers x wall time).

    python bench/load.py [--jobs 50] [--workers 2]
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


def write_csv(path: Path) -> None:
    t = np.arange(0.0, 10.0 + 1e-9, 0.2)
    sol = solve_ivp(
        lambda _t, y: [y[1], (40.0 - 1.6 * y[1] - 4.4 * y[0]) / 1.1],
        (0.0, 10.0), [0.0, 0.0], t_eval=t, rtol=1e-10,
    )  # fmt: skip
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
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="fmuid-bench-") as tmp:
        data_dir = Path(tmp)
        csv = data_dir / "step.csv"
        write_csv(csv)
        proc, url = start_service(data_dir, args.workers)
        try:
            run(url, csv, args.jobs, args.workers)
        finally:
            proc.terminate()
            proc.wait()


def run(url: str, csv: Path, n_jobs: int, workers: int) -> None:
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
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")


if __name__ == "__main__":
    main()
