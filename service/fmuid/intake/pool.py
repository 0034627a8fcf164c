"""A few long-lived processes that check submissions, so that no upload stalls the service.

Each process runs :mod:`fmuid.intake.vet` (started on first use, restarted after it ends; the
check's time counts from its first line, written once its imports are done), leads
its own session and checks one submission at a time. :meth:`VettingPool.run` lets at most
``size`` submissions in at once; the others wait without holding a thread, and after
``wait_s`` get 503. A check that outlasts ``timeout_s`` has its process killed together with
everything it started (every process of its session), and the answer is a 422 naming the limit.
"""

from __future__ import annotations

import json
import logging
import select
import signal
import subprocess
import sys
import threading
from collections.abc import Callable
from queue import LifoQueue
from typing import Any, TypeVar

import anyio
import anyio.to_thread

from fmuid.intake.vet import COMMAND, READY, VetTask
from fmuid.jobs.reaper import kill_tree
from fmuid.processes import kill_session

logger = logging.getLogger(__name__)

T = TypeVar("T")

START_TIMEOUT_S = 120.0
"""Longest start of a checking process (its imports), not counted in the check's time."""


class PoolBusy(Exception):
    """No checking process became free within the wait."""


class _Checker:
    """One checking process and its pipes."""

    def __init__(self, memory_mb: int):
        self.proc = subprocess.Popen(
            [sys.executable, "-c", COMMAND, str(memory_mb)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            start_new_session=True,
        )

    def wait_ready(self, timeout: float) -> bool:
        """Wait for the process's first line, which it writes once its imports are done."""
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        return bool(ready) and self.proc.stdout.readline().decode().strip() == READY

    def alive(self) -> bool:
        return self.proc.poll() is None

    def ask(self, task: VetTask, timeout: float) -> dict[str, Any] | None:
        """Send a task; return the answer, or None when none came within ``timeout`` seconds."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        try:
            self.proc.stdin.write(task.to_json().encode() + b"\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            return None
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        line = self.proc.stdout.readline() if ready else b""
        return json.loads(line) if line else None

    def kill(self) -> None:
        """Kill the process, every process below it and every one of its session; reap it."""
        kill_tree(self.proc.pid)
        kill_session(self.proc.pid)
        self.proc.wait()


class VettingPool:
    """Checking processes shared by the submissions of one service.

    Parameters
    ----------
    size
        Submissions checked at the same time (one process each).
    memory_mb
        Address space of each process [MiB].
    timeout_s
        Wall-clock time of one check [s].
    wait_s
        Longest wait of a submission for a free process [s].

    """

    def __init__(self, size: int, memory_mb: int, timeout_s: float, wait_s: float):
        self.size = size
        self.memory_mb = memory_mb
        self.timeout_s = timeout_s
        self.wait_s = wait_s
        self._idle: LifoQueue[_Checker | None] = LifoQueue()  # a warm process first
        for _ in range(size):
            self._idle.put(None)
        self._all: set[_Checker] = set()
        self._lock = threading.Lock()
        self._gate: anyio.CapacityLimiter | None = None
        self._threads: anyio.CapacityLimiter | None = None

    async def run(self, function: Callable[..., T], *args: Any) -> T:
        """Run ``function(*args)`` in a thread once one of the ``size`` places is free.

        Raises
        ------
        PoolBusy
            When no place became free within ``wait_s``.

        """
        if self._gate is None or self._threads is None:
            self._gate = anyio.CapacityLimiter(self.size)
            self._threads = anyio.CapacityLimiter(self.size)
        token = object()
        acquired = False
        with anyio.move_on_after(self.wait_s):
            await self._gate.acquire_on_behalf_of(token)
            acquired = True
        if not acquired:
            raise PoolBusy(
                f"{self.size} submissions are being checked (FMUID_CHECK_WORKERS) and none"
                f" finished within {self.wait_s:g} s (FMUID_CHECK_WAIT_S); try again later"
            )
        try:
            return await anyio.to_thread.run_sync(function, *args, limiter=self._threads)
        finally:
            self._gate.release_on_behalf_of(token)

    def check(self, task: VetTask) -> dict[str, Any]:
        """Check one submission in a checking process (blocking; call it inside :meth:`run`)."""
        checker = self._idle.get()
        try:
            if checker is not None and not checker.alive():  # it ended itself to free memory
                self._forget(checker)
                checker.kill()
                checker = None
            if checker is None:
                checker = self._start()
                if not checker.wait_ready(START_TIMEOUT_S):
                    self._forget(checker)
                    checker.kill()
                    checker = None
                    detail = f"no checking process started within {START_TIMEOUT_S:g} s"
                    return {"ok": False, "status": 503, "detail": detail}
            answer = checker.ask(task, self.timeout_s)
            if answer is not None:
                return answer
            reason = self._why_no_answer(checker)
            self._forget(checker)
            checker = None
            return {"ok": False, "status": 422, "detail": reason}
        finally:
            self._idle.put(checker)

    def _why_no_answer(self, checker: _Checker) -> str:
        if checker.alive():
            checker.kill()
            return (
                f"checking the upload took longer than {self.timeout_s:g} s"
                " (FMUID_CHECK_TIMEOUT_S); it was stopped"
            )
        code = checker.proc.wait()
        kill_session(checker.proc.pid)
        if code == -signal.SIGXCPU:
            return f"checking the upload used more than {self.timeout_s:g} s of CPU time"
        return (
            f"checking the upload ended its process (exit status {code}); the upload may need"
            f" more than {self.memory_mb} MB (FMUID_CHECK_MEMORY_MB)"
        )

    def _start(self) -> _Checker:
        checker = _Checker(self.memory_mb)
        with self._lock:
            self._all.add(checker)
        return checker

    def _forget(self, checker: _Checker) -> None:
        with self._lock:
            self._all.discard(checker)

    def close(self) -> None:
        """Kill every checking process (when the service stops)."""
        with self._lock:
            checkers, self._all = list(self._all), set()
        for checker in checkers:
            if checker.alive():
                checker.kill()
