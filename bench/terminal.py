"""What the terminal user waits for: `fmuid --help`, and the end of a profile after Ctrl-C.

Ctrl-C is SIGINT to the command's process group (as a terminal sends it), 3 s into the profile
walk of the six tractor tire parameters (design 1, SNR 25, two worker processes).
"""

from __future__ import annotations

import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "testbed"))
sys.path.insert(0, str(ROOT / "service"))

from fmuid.model.builtin import builtin_fmu  # noqa: E402
from tractor_files import tractor_study  # noqa: E402

FMUID = [sys.executable, "-m", "fmuid.cli"]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "service")}  # this tree's fmuid, not an install


def help_seconds(runs: int = 7) -> float:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run([*FMUID, "--help"], capture_output=True, check=True, env=ENV)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def interrupt(folder: Path) -> tuple[float, int, bool]:
    args = tractor_study(folder, builtin_fmu("tractor_implement"))
    proc = subprocess.Popen(
        [*FMUID, "profile", *args, "--workers", "2"],
        cwd=folder,
        env=ENV,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    assert proc.stderr is not None
    for line in proc.stderr:
        if "profile: " in line:
            break
    time.sleep(3.0)
    t0 = time.perf_counter()
    os.killpg(proc.pid, signal.SIGINT)
    code = proc.wait()
    seconds = time.perf_counter() - t0
    time.sleep(0.2)
    try:
        os.killpg(proc.pid, 0)
        orphans = True
    except ProcessLookupError:
        orphans = False
    return seconds, code, orphans


def main() -> None:
    print(f"{'measure':<44} {'value':>10}")
    print(f"{'fmuid --help, median of 7 [s]':<44} {help_seconds():>10.3f}")
    with tempfile.TemporaryDirectory() as tmp:
        seconds, code, orphans = interrupt(Path(tmp))
    print(f"{'Ctrl-C during a profile: exit after [s]':<44} {seconds:>10.3f}")
    print(f"{'Ctrl-C during a profile: exit status':<44} {code:>10d}")
    print(f"{'Ctrl-C during a profile: processes left':<44} {str(orphans):>10}")


if __name__ == "__main__":
    main()
