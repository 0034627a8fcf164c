"""Parallel stages in Python: Ctrl-C stops them at once; a script without a guard runs once."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from design_cases import MSD_SPACE, MSD_SPEC
from tractor_files import tractor_study

SCRIPT = """
import json
import time
import fmuid
from fmuid.data import load_experiment, load_spec
from fmuid.experiment_design import space_from_json

with open("runs.txt", "a") as runs:
    runs.write("run\\n")


def progress(event):
    if event.stage == "profile":
        print("walking", flush=True)


try:
    {call}
    print("finished", flush=True)
except KeyboardInterrupt:
    print("KeyboardInterrupt", flush=True)
    input()  # stay alive while the test looks for workers
"""

CALLS = {
    "profile": 'fmuid.profile({fmu!r}, [load_experiment("d.csv")], load_spec("s.json"), '
    "workers=2, progress=progress)",
    "diagnose": 'fmuid.diagnose({fmu!r}, [load_experiment("d.csv")], load_spec("s.json"), '
    "workers=2)",
    "design": 'fmuid.design("msd", load_spec("s.json"), '
    'space_from_json(open("space.json").read()), workers=2)',
}
"""What the script runs: each parallel stage of the Python toolkit on two local workers."""


def _script(stage: str, fmu: Path | str) -> str:
    return SCRIPT.replace("{call}", CALLS[stage].format(fmu=str(fmu)))


def _grandchildren(pid: int) -> list[int]:
    """Live processes whose parent is a child of ``pid`` (the pool's workers under its server)."""
    parents: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[0] not in ("Z", "X"):
            parents[int(stat.parent.name)] = int(fields[1])
    children = {p for p, parent in parents.items() if parent == pid}
    return [p for p, parent in parents.items() if parent in children]


def _interruptible() -> None:
    """Give the script the SIGINT a terminal or notebook has, however pytest itself was started.

    A command started with ``&`` by a shell without job control (a CI script, ``nohup``)
    inherits SIGINT ignored, and Python then installs no ``KeyboardInterrupt`` handler.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def workers_of(proc: subprocess.Popen[str], timeout: float = 300.0) -> list[int]:
    """Wait until the script's pool has its two workers; return their pids."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, "the script ended before its pool started"
        workers = _grandchildren(proc.pid)
        if len(workers) == 2:
            return workers
        time.sleep(0.05)
    raise AssertionError(f"no two-worker pool within {timeout:.0f} s")


@pytest.mark.slow
@pytest.mark.parametrize("stage", ["profile", "diagnose", "design"])
def test_sigint_stops_a_two_worker_stage_and_its_workers(tractor_fmu, tmp_path, stage):
    if stage == "design":
        (tmp_path / "s.json").write_text(json.dumps(MSD_SPEC))
        (tmp_path / "space.json").write_text(json.dumps(MSD_SPACE))
    else:
        tractor_study(tmp_path, tractor_fmu)
    (tmp_path / "script.py").write_text(_script(stage, tractor_fmu))
    proc = subprocess.Popen(
        [sys.executable, "script.py"],
        cwd=tmp_path,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        preexec_fn=_interruptible,
    )
    assert proc.stdout is not None and proc.stdin is not None
    try:
        workers_of(proc)
        proc.send_signal(signal.SIGINT)  # what a notebook's interrupt does: the kernel alone
        sent = time.monotonic()
        line = proc.stdout.readline()
        while line.strip() == "walking":
            line = proc.stdout.readline()
        waited = time.monotonic() - sent
        assert line.strip() == "KeyboardInterrupt"
        assert waited < 2.0, f"KeyboardInterrupt {waited:.1f} s after SIGINT"
        assert _grandchildren(proc.pid) == [], "a pool worker outlived the interrupt"
        assert (tmp_path / "runs.txt").read_text() == "run\n"  # no worker re-ran the script
    finally:
        proc.kill()
        proc.wait()


@pytest.mark.slow
@pytest.mark.parametrize("run", [["script.py"], ["-m", "script"]], ids=["file", "module"])
def test_a_script_without_main_guard_runs_once(msd_parallel_fmu, tmp_path, run):
    (tmp_path / "d.csv").write_text(
        "time,f,x\n" + "".join(f"{t / 4},40,{10 * (1 - 0.9**t):.6f}\n" for t in range(25))
    )
    spec = {
        "parameters": {
            n: {"start": v, "lower": 0.01, "upper": 50.0}
            for n, v in {"k1": 3.0, "k2": 1.4, "b": 1.6}.items()
        },
        "fixed": {"m": 1.1},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": 0.1}},
        "global_search": False,
    }
    (tmp_path / "s.json").write_text(json.dumps(spec))
    (tmp_path / "script.py").write_text(_script("profile", msd_parallel_fmu))
    proc = subprocess.run(
        [sys.executable, *run], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "finished"
    assert (tmp_path / "runs.txt").read_text() == "run\n"
