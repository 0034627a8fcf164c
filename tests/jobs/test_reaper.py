"""A job leader ends with the service: itself and every process below it, whatever its parent
does and however fast its own threads start processes (checked in ``/proc``)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

from fmuid.processes import is_alive

MARK = "3519"
LEADER = f"""
import subprocess, sys, time
from fmuid.jobs.reaper import end_tree_on_parent_death
from fmuid.processes import become_subreaper
become_subreaper()
end_tree_on_parent_death(int(sys.argv[1]))
detached = subprocess.Popen(["sleep", "{MARK}"], start_new_session=True)
print(detached.pid, flush=True)
while True:
    subprocess.Popen(["sleep", "{MARK}"])
    time.sleep(0.005)
"""
"""A leader whose main thread never stops starting processes, one of them in its own session."""


def sleepers() -> set[int]:
    """Pids of the live ``sleep MARK`` processes."""
    found = set()
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            cmdline = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        if cmdline == f"sleep\0{MARK}\0".encode() and is_alive(int(entry.name)):
            found.add(int(entry.name))
    return found


def wait_until(condition, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return condition()


def test_the_services_death_ends_the_leader_and_its_tree_while_its_parent_lives():
    service = subprocess.Popen(["sleep", "60"])  # stands for the service; the test is the parent
    leader = subprocess.Popen(
        [sys.executable, "-c", LEADER, str(service.pid)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert leader.stdout is not None
        detached = int(leader.stdout.readline())
        assert wait_until(lambda: len(sleepers()) >= 5, 20)
        assert detached in sleepers()
        service.kill()
        service.wait()
        assert leader.wait(timeout=20) == -signal.SIGKILL  # frozen, then killed: no exit path ran
        assert wait_until(lambda: not sleepers(), 10), sleepers()
    finally:
        service.kill()
        leader.kill()
        for pid in sleepers():
            subprocess.run(["kill", "-9", str(pid)], check=False)
