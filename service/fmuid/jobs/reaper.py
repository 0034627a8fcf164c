"""Every process a job or a check starts ends with it, even one that left its session.

A process that calls ``setsid()`` leaves its process group, so killing the group of a job misses
it; one that also drops its environment loses the tag a restart looks for
(:mod:`fmuid.jobs.proc`). The job leader and the probe of an upload therefore become *child
subreapers* (``PR_SET_CHILD_SUBREAPER``, Linux 3.4+): an orphan among their descendants is
re-parented to them instead of to init, so while they live every process they started, however
it detached, is in their tree of ``/proc/<pid>/stat`` parents. :func:`kill_tree` freezes that
tree (``SIGSTOP``, so nothing forks meanwhile), then kills it; :func:`end_tree` repeats that
until no descendant lives, since the leader's own threads may still start processes. A leader
ends its tree when its job ends and when the service dies (:func:`end_tree_on_parent_death`).

Where the call is refused (not Linux, or a kernel without it),
:func:`fmuid.processes.become_subreaper` returns ``False`` and orphans go to init: the group kill
and the restart's search by tag still end every process that kept its group or its environment,
but not one that dropped both.
"""

from __future__ import annotations

import logging
import os
import select
import signal
import threading
import time

from fmuid.processes import die_with_parent, is_alive, process_stats

logger = logging.getLogger(__name__)

FREEZE_ROUNDS = 50
"""Looks at the tree while freezing it: a tree that still grows after that many is killed as is."""
END_ROUNDS = 100
"""Kills of the whole tree :func:`end_tree` tries before it gives up on a tree that regrows."""
END_PAUSE_S = 0.01
"""Pause between those kills, so that killed processes have ended when the tree is looked at."""
OWNER_POLL_S = 0.5
"""How often a leader looks for its service where the kernel gives no process descriptor."""


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


def kill_tree(root: int, include_root: bool = True, spare: int | None = None) -> list[int]:
    """Freeze, then SIGKILL, ``root``'s descendants (and ``root`` unless told not to).

    ``spare`` (the calling process, when it is one of the descendants) is left alone.

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
        new = [pid for pid in descendants(root) if pid not in frozen and pid != spare]
        if not new:
            break
        for pid in new:
            _signal(pid, signal.SIGSTOP)
        frozen.update(new)
    for pid in frozen:
        _signal(pid, signal.SIGKILL)
        _signal(pid, signal.SIGCONT)
    return sorted(frozen)


def end_tree(root: int) -> None:
    """Kill ``root``'s descendants (not ``root``) until a look at its tree finds none alive.

    ``root``'s other threads may go on starting processes (loading an FMU whose constructor
    forks, starting pool workers) while one freeze runs, so a child born after its last look
    would outlive ``root``: the tree is killed again until nothing in it lives.
    """
    for _ in range(END_ROUNDS):
        kill_tree(root, include_root=False)
        if not any(is_alive(pid) for pid in descendants(root)):
            return
        time.sleep(END_PAUSE_S)
    logger.warning("process %d: its tree still grows after %d kills", root, END_ROUNDS)


def reap_children() -> None:
    """Collect the exit status of every ended child (orphans re-parented to a subreaper)."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


def _pidfd(pid: int | None) -> int | None:
    """Open a descriptor readable once ``pid`` has ended (Linux 5.3+); ``None`` where none."""
    if pid is None:
        return None
    try:
        return os.pidfd_open(pid)
    except (AttributeError, OSError):
        return None


def _wait_for_end(wakeup: int, owner: int | None) -> None:
    """Return once ``SIGTERM`` arrived (its byte on ``wakeup``) or ``owner`` has ended."""
    owner_fd = _pidfd(owner)
    watched = [wakeup] if owner_fd is None else [wakeup, owner_fd]
    poll = OWNER_POLL_S if owner is not None and owner_fd is None else None
    while True:
        ready, _, _ = select.select(watched, [], [], poll)
        if owner_fd in ready:
            return
        if wakeup in ready and signal.SIGTERM in os.read(wakeup, 64):
            return
        if poll is not None and owner is not None and not is_alive(owner):
            return


def _undertake(leader: int) -> None:
    """Have a child process freeze ``leader`` (all its threads at once), then kill its tree.

    Killing the tree from one of ``leader``'s own threads leaves the others running: they could
    start processes after the last look, or record the job as failed when its workers die.
    The child freezes the whole leader first, so neither can happen, then kills the leader and
    everything below it except itself. Returns only when the child could not do that.
    """
    try:
        child = os.fork()
    except OSError:
        return
    if child == 0:
        try:
            kill_tree(leader, spare=os.getpid())
        finally:
            os._exit(0)
    os.waitpid(child, 0)


def end_tree_on_parent_death(owner: int | None = None) -> None:
    """When this process's parent or ``owner`` dies, kill this process and its descendants.

    The kernel sends ``SIGTERM`` at the parent's death (``PR_SET_PDEATHSIG``); the signal's
    C handler writes to a wake-up pipe, which a thread reads, so the tree is ended even while
    the main thread is inside the FMU's native code. The thread also watches ``owner`` (the
    service), because the parent may be a process between the two (the warm server that
    forked this one) whose own end does not follow the service's at once. The tree, this
    process included, is then killed by a child process (:func:`_undertake`).
    """
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)
    signal.signal(signal.SIGTERM, lambda *_: None)
    parent = os.getppid()

    def watch() -> None:
        _wait_for_end(read_end, owner)
        _undertake(os.getpid())
        end_tree(os.getpid())  # only when the undertaker could not be started
        os._exit(128 + signal.SIGTERM)

    threading.Thread(target=watch, name="fmuid-end-tree", daemon=True).start()
    die_with_parent(signal.SIGTERM)
    if os.getppid() != parent:  # the parent died before the request took effect
        os.kill(os.getpid(), signal.SIGTERM)
