"""Every process a job or a check starts ends with it, even one that left its session.

A process that calls ``setsid()`` leaves its process group, so killing the group of a job misses
it; one that also drops its environment loses the tag a restart looks for
(:mod:`fmuid.jobs.proc`). The job leader and the probe of an upload therefore become *child
subreapers* (``PR_SET_CHILD_SUBREAPER``, Linux 3.4+): an orphan among their descendants is
re-parented to them instead of to init, so while they live every process they started, however
it detached, is in their tree of ``/proc/<pid>/stat`` parents. :func:`kill_tree` freezes that
tree (``SIGSTOP``, so nothing forks meanwhile), then kills it. A leader ends its tree when its
job ends and when the service dies (:func:`end_tree_on_parent_death`).

Where the call is refused (not Linux, or a kernel without it),
:func:`fmuid.processes.become_subreaper` returns ``False`` and orphans go to init: the group kill
and the restart's search by tag still end every process that kept its group or its environment,
but not one that dropped both.
"""

from __future__ import annotations

import logging
import os
import signal
import threading

from fmuid.processes import die_with_parent, process_stats

logger = logging.getLogger(__name__)

FREEZE_ROUNDS = 50
"""Looks at the tree while freezing it: a tree that still grows after that many is killed as is."""


def _parents() -> dict[int, int]:
    """Map every live pid to its parent's pid."""
    return {pid: int(fields[1]) for pid, fields in process_stats()}


def descendants(root: int) -> list[int]:
    """Return the pids of every process below ``root`` in the tree of parents."""
    children: dict[int, list[int]] = {}
    for pid, parent in _parents().items():
        children.setdefault(parent, []).append(pid)
    found: list[int] = []
    stack = [root]
    while stack:
        for child in children.get(stack.pop(), []):
            found.append(child)
            stack.append(child)
    return found


def _signal(pid: int, signum: int) -> None:
    try:
        os.kill(pid, signum)
    except (ProcessLookupError, PermissionError):
        pass


def kill_tree(root: int, include_root: bool = True) -> list[int]:
    """Freeze, then SIGKILL, ``root``'s descendants (and ``root`` unless told not to).

    Returns
    -------
    list of int
        The pids that were signalled.

    """
    frozen: set[int] = set()
    if include_root:
        _signal(root, signal.SIGSTOP)
        frozen.add(root)
    for _ in range(FREEZE_ROUNDS):
        new = [pid for pid in descendants(root) if pid not in frozen]
        if not new:
            break
        for pid in new:
            _signal(pid, signal.SIGSTOP)
        frozen.update(new)
    for pid in frozen:
        _signal(pid, signal.SIGKILL)
        _signal(pid, signal.SIGCONT)
    return sorted(frozen)


def reap_children() -> None:
    """Collect the exit status of every ended child (orphans re-parented to a subreaper)."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


def end_tree_on_parent_death() -> None:
    """When this process's parent dies, kill every descendant of this process, then exit.

    The kernel sends ``SIGTERM`` at the parent's death (``PR_SET_PDEATHSIG``); the signal's
    C handler writes to a wake-up pipe, which a thread reads, so the tree is ended even while
    the main thread is inside the FMU's native code.
    """
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)
    signal.signal(signal.SIGTERM, lambda *_: None)
    parent = os.getppid()

    def watch() -> None:
        while os.read(read_end, 1) != bytes([signal.SIGTERM]):
            continue
        kill_tree(os.getpid(), include_root=False)
        os._exit(128 + signal.SIGTERM)

    threading.Thread(target=watch, name="fmuid-end-tree", daemon=True).start()
    die_with_parent(signal.SIGTERM)
    if os.getppid() != parent:  # the parent died before the request took effect
        os.kill(os.getpid(), signal.SIGTERM)
