"""Process hygiene primitives, checked against /proc and the kernel's own answers."""

import os
import subprocess
import sys
import time

from fmuid.processes import is_alive, kill_group


def test_a_zombie_is_not_alive_and_a_reaped_child_is_gone():
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    deadline = time.monotonic() + 10
    while is_alive(child.pid) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert not is_alive(child.pid)  # exited, not yet waited for: a zombie
    assert child.wait() == 0
    assert not is_alive(child.pid)
    assert is_alive(os.getpid())


def test_kill_group_ends_the_group_and_is_silent_once_it_is_gone():
    leader = subprocess.Popen(
        [sys.executable, "-c", "import time; time.sleep(60)"], start_new_session=True
    )
    kill_group(leader.pid)
    assert leader.wait(timeout=10) == -9
    kill_group(leader.pid)


def test_limit_memory_turns_a_large_allocation_into_memory_error():
    code = (
        "from fmuid.processes import limit_memory, memory_limit_mb\n"
        "limit_memory(300)\n"
        "assert memory_limit_mb() == 300\n"
        "try:\n"
        "    bytearray(400 * 1024 * 1024)\n"
        "except MemoryError:\n"
        "    raise SystemExit(3)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 3, proc.stderr
