"""Turn the way a job process ended into a message a user can act on.

Job processes run with ``PYTHONFAULTHANDLER=1`` and their stderr in a log file, so a fatal
signal leaves a Python traceback there; the innermost FMPy frame names the FMI call that was
running (``doStep`` -> ``fmi2DoStep`` or ``fmi3DoStep``). The job process writes the FMU's FMI
version to the log first (:data:`FMI_VERSION_LINE`), which says which of the two it was.
"""

from __future__ import annotations

import linecache
import re
import signal

_FATAL = re.compile(r"Fatal Python error: (?P<what>[^\n]+)")
_FRAME = re.compile(
    r'^\s+File "(?P<file>[^"]+)", line (?P<line>\d+) in (?P<func>\w+)', re.MULTILINE
)
_FMI_NAME = re.compile(r"fmi[23][A-Z]\w*")
FMI_VERSION_LINE = "fmuid job: FMI version "
STORE_FAILED_EXIT = 75
"""Exit status of a job process that could not write its outcome to the job store."""
_VERSION = re.compile(re.escape(FMI_VERSION_LINE) + r"(\d)")
# what allocators print when an allocation fails (xmalloc-style C, C++'s std::bad_alloc, Python)
_OUT_OF_MEMORY = re.compile(r"out of memory|bad_alloc|MemoryError|Cannot allocate memory", re.I)
_SIGNAL_NAMES: dict[int, str] = {
    signal.SIGSEGV: "segmentation fault",
    signal.SIGBUS: "bus error",
    signal.SIGFPE: "floating-point exception",
    signal.SIGILL: "illegal instruction",
    signal.SIGABRT: "abort",
}


_KNOWN = {int(s) for s in signal.Signals}


def fmi_call_in_traceback(log: str) -> str | None:
    """Return the FMI function running at the last fatal error in a job log, if known.

    The innermost Python frame is the one that called into the FMU. Its source line (and the
    next, where a call and its error check share a statement) names the FMI function in fmuid's
    simulator (``do_step(...)`` checked as ``"fmi2DoStep"``); FMPy's wrappers are named after it
    (``doStep``).

    Parameters
    ----------
    log
        Text written by the job process (and its children) to stderr.

    Returns
    -------
    str or None
        E.g. ``"fmi2DoStep"`` or ``"fmi3DoStep"``; ``None`` when the log has no fatal-error
        traceback naming one.

    """
    fatal = list(_FATAL.finditer(log))
    if not fatal:
        return None
    version = _VERSION.search(log)
    prefix = f"fmi{version[1]}" if version else None
    frames = list(_FRAME.finditer(_crashed_thread(log, fatal[-1].end())))
    if frames:
        innermost = frames[0]
        lineno = int(innermost["line"])
        source = "".join(linecache.getline(innermost["file"], n) for n in (lineno, lineno + 1))
        named = _FMI_NAME.findall(source)
        if named:
            return next((n for n in named if prefix and n.startswith(prefix)), named[0])
    for frame in frames:
        if "fmpy" in frame["file"] and frame["func"] not in ("w", "wrapper"):
            func = frame["func"]
            if _FMI_NAME.fullmatch(func):
                return func
            module = re.search(r"(fmi[23])\.py$", frame["file"])
            where = module[1] if module else prefix or "fmi2"
            return where + func[0].upper() + func[1:]
    return None


def _crashed_thread(log: str, start: int) -> str:
    """Return the stack of the thread that crashed (faulthandler also lists the other threads)."""
    current = log.find("Current thread", start)
    if current == -1:
        return log[start:]
    end = log.find("\n\n", current)
    return log[current : end if end != -1 else len(log)]


def memory_message(memory_mb: int) -> str:
    """Return the reason given to a job that ran out of its address space."""
    return f"exceeded the memory limit of {memory_mb} MB (FMUID_JOB_MEMORY_MB)"


def crash_message(log: str, memory_mb: int) -> str | None:
    """Describe a fatal signal recorded in a job log, or return ``None`` when there is none.

    A crash that follows an allocator's out-of-memory message is the memory limit at work.
    """
    fatal = list(_FATAL.finditer(log))
    if not fatal:
        return None
    where = fmi_call_in_traceback(log)
    place = f"in {where}" if where else "in native code"
    what = fatal[-1]["what"].strip().lower()
    if _OUT_OF_MEMORY.search(log):
        return f"{memory_message(memory_mb)}: the FMU gave up ({what}) {place}"
    return f"the FMU crashed ({what}) {place}"


def exit_message(returncode: int, log: str, memory_mb: int) -> str:
    """Describe why a job process ended without recording a result or an error.

    Parameters
    ----------
    returncode
        ``Popen.returncode``: negative for a signal.
    log
        The job's stderr log.
    memory_mb
        The memory limit the process ran under [MiB].

    """
    if returncode < 0:
        sig = -returncode
        if sig == signal.SIGKILL:
            return (
                "the job process was killed (SIGKILL) from outside the service: by an operator"
                " or by the system's out-of-memory killer (the system log tells which); the"
                f" per-job memory limit is {memory_mb} MB (FMUID_JOB_MEMORY_MB)"
            )
        if sig == signal.SIGALRM:
            return "the job process was ended at its time limit (SIGALRM, FMUID_JOB_TIMEOUT_S)"
        if sig not in _SIGNAL_NAMES:
            what = signal.Signals(sig).name if sig in _KNOWN else f"signal {sig}"
            return (
                f"the job process was stopped by {what} from outside the service (an operator"
                " or the system), not by the FMU"
            )
        name = _SIGNAL_NAMES[sig]
        where = fmi_call_in_traceback(log)
        place = f" in {where}" if where else " in native code"
        if _OUT_OF_MEMORY.search(log):
            return f"{memory_message(memory_mb)}: the FMU gave up ({name}){place}"
        return f"the FMU crashed ({name}){place}; the job process ended by signal {sig}"
    if returncode == STORE_FAILED_EXIT:
        return "the job store could not be written while the job ran (disk full or I/O error)"
    if _OUT_OF_MEMORY.search(log):
        return memory_message(memory_mb)
    return f"the job process exited with status {returncode} without a result"
