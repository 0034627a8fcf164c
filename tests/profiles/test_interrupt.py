"""A Python user's parallel profile: Ctrl-C stops it at once; a script without a guard runs once."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tractor_files import tractor_study

SCRIPT = """
import time
import fmuid
from fmuid.data import load_experiment, load_spec

with open("runs.txt", "a") as runs:
    runs.write("run\\n")


def progress(event):
    if event.stage == "profile":
        print("walking", flush=True)


try:
    fmuid.profile({fmu!r}, [load_experiment("d.csv")], load_spec("s.json"), workers=2,
                  progress=progress)
    print("finished", flush=True)
except KeyboardInterrupt:
    print("KeyboardInterrupt", flush=True)
    input()  # stay alive while the test looks for workers
"""


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


@pytest.mark.slow
def test_sigint_stops_a_two_worker_profile_and_its_workers(tractor_fmu, tmp_path):
    tractor_study(tmp_path, tractor_fmu)
    (tmp_path / "script.py").write_text(SCRIPT.format(fmu=str(tractor_fmu)))
    proc = subprocess.Popen(
        [sys.executable, "script.py"],
        cwd=tmp_path,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None and proc.stdin is not None
    try:
        assert proc.stdout.readline().strip() == "walking"
        assert len(_grandchildren(proc.pid)) == 2  # both workers walk branches
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
    (tmp_path / "script.py").write_text(SCRIPT.format(fmu=str(msd_parallel_fmu)))
    proc = subprocess.run(
        [sys.executable, *run], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "finished"
    assert (tmp_path / "runs.txt").read_text() == "run\n"
