"""How often one process opens an FMU's zip and parses XML: a parse, a CLI diagnosis, a pool worker.

Counts every ``zipfile.ZipFile`` opened on an ``.fmu`` file or on bytes in memory (and every
``zipfile.is_zipfile`` check) and every XML document parsed by ElementTree or lxml, whoever
calls them (fmuid or fmpy), in three situations of the built-in ``msd`` model:

- ``parse + 2 simulators``: ``FmuModel(path)``, then ``get_simulator`` in two threads;
- ``CLI diagnosis``: ``fmuid diagnose --workers 1`` on ``examples/step.csv`` and ``spec.json``
  (the diagnosing process only);
- ``pool worker``: each worker of a 2-worker pool (its set-up parse, then a simulator).

Each case runs in a fresh process. Run it on a tree to compare (the counts do not depend on the
machine)::

    PYTHONPATH=service python bench/fmu_world.py
"""

from __future__ import annotations

import collections
import json
import os
import subprocess
import sys
import tempfile
import threading
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from typing import Any

from lxml import etree

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
COUNTS: collections.Counter[str] = collections.Counter()


def _count(owner: Any, name: str, key: str, counts: Any = lambda *a: True) -> None:
    real = getattr(owner, name)

    def counted(*args: Any, **kwargs: Any) -> Any:
        COUNTS[key] += bool(counts(*args))
        return real(*args, **kwargs)

    setattr(owner, name, counted)


def _on_fmu(archive: Any, file: Any = None, *args: Any) -> bool:
    return hasattr(file, "read") or str(file).endswith(".fmu")


def _install() -> None:
    """Count from now on (in this process and in the processes it forks)."""
    _count(zipfile.ZipFile, "__init__", "zip", _on_fmu)
    _count(zipfile, "is_zipfile", "zip")
    for owner in (ET, etree):
        for name in ("fromstring", "parse", "XML"):
            _count(owner, name, "xml")


def _seen() -> tuple[int, int]:
    return COUNTS["zip"], COUNTS["xml"]


def in_worker(model: Any) -> tuple[int, tuple[int, int]]:
    """In a pool worker: what its set-up and one simulator opened and parsed."""
    from fmuid.model.registry import get_simulator

    get_simulator(model)
    return os.getpid(), _seen()


def _parse(fmu: Path, folder: Path) -> tuple[int, int]:
    from fmuid.model.fmu import FmuModel
    from fmuid.model.registry import get_simulator

    model = FmuModel(fmu)
    get_simulator(model)
    thread = threading.Thread(target=get_simulator, args=(model,))
    thread.start()
    thread.join()
    return _seen()


def _diagnosis(fmu: Path, folder: Path) -> tuple[int, int]:
    from fmuid.cli import main

    args = ["diagnose", "--fmu", str(fmu), "--data", str(EXAMPLES / "step.csv")]
    args += ["--spec", str(EXAMPLES / "spec.json"), "--out", str(folder / "d.json")]
    if main([*args, "--workers", "1"]) != 0:
        raise SystemExit("the diagnosis failed")
    return _seen()


def _workers(fmu: Path, folder: Path) -> list[tuple[int, int]]:
    from fmuid.engine.run import open_engine
    from fmuid.model.fmu import FmuModel

    model = FmuModel(fmu)
    with open_engine(model, workers=2, preload=["fmu_world"]) as engine:
        seen = engine.map(in_worker, [model] * 4)
    return sorted(set(dict(seen).values()))


CASES = {"parse": _parse, "diagnosis": _diagnosis, "workers": _workers}


def _case(name: str) -> None:
    """Run one case in this (fresh) process and print its counts as JSON."""
    from fmuid.model.builtin import builtin_fmu

    fmu = builtin_fmu("msd")
    COUNTS.clear()  # building the FMU is not counted
    with tempfile.TemporaryDirectory() as folder:
        seen = CASES[name](fmu, Path(folder))
    print(json.dumps(seen))


def main() -> None:
    """Print the table: each case in a process of its own."""
    here = str(Path(__file__).parent)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([here, os.environ.get("PYTHONPATH", "")])}
    labels = {
        "parse": "parse + 2 simulators",
        "diagnosis": "CLI diagnosis",
        "workers": "pool worker",
    }
    print(f"{'one process':<22} {'zip opens':>9} {'XML parses':>10}")
    for name, label in labels.items():
        proc = subprocess.run(
            [sys.executable, "-m", "fmu_world", name],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
        seen = json.loads(proc.stdout.strip().splitlines()[-1])
        for zips, xmls in seen if name == "workers" else [seen]:
            print(f"{label:<22} {zips:>9} {xmls:>10}")


if __name__ == "__main__" and len(sys.argv) > 1:  # one case, in the module fmu_world
    import fmu_world

    fmu_world._case(sys.argv[1])
elif __name__ == "__main__":
    main()
else:  # imported for a case, or preloaded by the pool's forkserver: its workers fork counting
    _install()
