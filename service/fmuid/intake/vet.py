"""Check a submission's files in a process of its own: ``python -m fmuid.intake.vet MEMORY_MB``.

The service (:mod:`fmuid.intake.pool`) keeps a few of these processes and sends each a
:class:`VetTask` as one JSON line on stdin; the process answers one JSON line on its stdout:
``{"ok": true, "model_name": ...}`` or ``{"ok": false, "status": 422, "detail": ...}``. Every
parse of uploaded bytes (spec, CSV files, a design's space, ``modelDescription.xml``) and the
probe of the FMU's binary happen here, never in the service, so that no upload can stall the
service's other requests. The process lowers its CPU priority, limits its own address space
and, per task, its CPU time; it leads its own session, so that the service can kill it and
everything it started at once; and it ends when its parent does. It is a child subreaper
(:mod:`fmuid.jobs.reaper`): whatever a probed binary started, even in a session of its own, is
re-parented to it when the probe ends, and killed after every task.
"""

from __future__ import annotations

import json
import logging
import os
import re
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from fmuid.data import InputLimits, Spec, load_experiment, spec_from_json
from fmuid.data.checks import check_test_data
from fmuid.data.limits import over_limit
from fmuid.errors import FmuidError, SpecError
from fmuid.estimation.check import check_study
from fmuid.intake.fmucheck import FmuLimits, check_fmu
from fmuid.jobs.reaper import end_tree, reap_children
from fmuid.jobs.records import TEST_DATA
from fmuid.model.fmu import FmuModel
from fmuid.processes import allow_cpu_seconds, become_subreaper, limit_memory, memory_limit_mb

logger = logging.getLogger(__name__)

READY = '{"ready": true}'
"""The first line a checking process writes, once it has imported everything."""
NICENESS = 10
"""Checking processes yield the CPU to the service (health, polls) and to the jobs; the
service lowers the priority before the imports (:data:`COMMAND`)."""
COMMAND = (
    f"import os, runpy; os.nice({NICENESS});"
    " runpy.run_module('fmuid.intake.vet', run_name='__main__', alter_sys=True)"
)
"""``python -c COMMAND MEMORY_MB`` starts a checking process at low priority."""
RECYCLE_RSS_MB = 400
"""A checking process that holds more than this after a task exits (the service starts anew)."""


@dataclass(frozen=True)
class VetTask:
    """Files of one submission in a folder, and the limits to check them against.

    Attributes
    ----------
    workdir
        The folder: ``spec.json``, ``data/<name>.csv`` and the FMU file.
    data_names
        Base names of the CSV files in ``workdir/data``, in upload order.
    fmu_file
        Name of the FMU file in ``workdir``.
    fmu_name
        The name the uploader gave the FMU (for messages); None for a built-in FMU, which is
        trusted and only read.
    cpu_seconds
        CPU time the check may use.
    space_file
        Name of a design job's experiment space in ``workdir`` (such a job has no CSV files).
    test_names
        Base names of the held-out CSV files in ``workdir/test_data``.

    """

    workdir: str
    data_names: list[str]
    fmu_file: str
    fmu_name: str | None
    cpu_seconds: float
    input_limits: dict[str, int] = field(default_factory=dict)
    fmu_limits: dict[str, Any] = field(default_factory=dict)
    space_file: str | None = None
    test_names: list[str] = field(default_factory=list)

    def to_json(self) -> str:
        """One line of JSON."""
        return json.dumps(asdict(self))


MAX_NUMBER_CHARS = 100
"""Longest number accepted in a spec or a space (Python's int parser stops at 4,300 digits)."""
_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')
_NUMBER = re.compile(rf"[0-9eE.+-]{{{MAX_NUMBER_CHARS + 1},}}")
_BRACKET = re.compile(r"[\[\]{}]")


def check_json_shape(text: str, name: str, limits: InputLimits) -> None:
    """Refuse JSON with a number too long or nesting too deep, before any parser sees it.

    Raises
    ------
    SpecError
        Naming the field (``spec`` or ``space``) and the limit.

    """
    bare = _STRING.sub('""', text)
    long = _NUMBER.search(bare)
    if long:
        raise SpecError(
            f"{name}: a number of {len(long[0])} characters, more than the limit of"
            f" {MAX_NUMBER_CHARS}"
        )
    depth = 0
    for bracket in _BRACKET.finditer(bare):
        depth += 1 if bracket[0] in "[{" else -1
        if depth > limits.max_spec_depth:
            what = over_limit("nested arrays and objects", "max_spec_depth", limits)
            raise SpecError(f"{name}: {what}")


def vet(task: VetTask) -> dict[str, Any]:
    """Check the spec, the FMU, each CSV file (or a design's space) and how they fit together.

    Returns
    -------
    dict
        ``{"ok": True, "model_name": ...}``, or ``{"ok": False, "status": 422, "detail": ...}``
        naming the problem.

    """
    workdir = Path(task.workdir)
    input_limits = InputLimits(**task.input_limits)
    try:
        text = (workdir / "spec.json").read_text(encoding="utf-8")
        check_json_shape(text, "spec", input_limits)
        spec = spec_from_json(text, "spec", input_limits)
        fmu_path = workdir / task.fmu_file
        if task.fmu_name is None:
            model = FmuModel(fmu_path)
        else:
            model = check_fmu(fmu_path, task.fmu_name, FmuLimits(**task.fmu_limits))
        if task.space_file is not None:
            _check_design(workdir / task.space_file, spec, model, input_limits)
            return {"ok": True, "model_name": model.model_name}
        experiments = [
            load_experiment(workdir / "data" / name, input_limits) for name in task.data_names
        ]
        model = check_study(model, spec, experiments)
        tests = [load_experiment(workdir / TEST_DATA / n, input_limits) for n in task.test_names]
        check_test_data(spec, model.parameters, model.inputs, model.outputs, tests)
    except FmuidError as exc:
        return {"ok": False, "status": 422, "detail": str(exc)}
    return {"ok": True, "model_name": model.model_name}


def _check_design(path: Path, spec: Spec, model: FmuModel, limits: InputLimits) -> None:
    """Check a design job's experiment space (held to the spec's size limit) against the FMU.

    :mod:`fmuid.experiment_design` is imported on the first design check only: it brings the
    engine (about 3 s and 100 MB), which the other checks do not need.
    """
    from fmuid.experiment_design.space import check_design, space_from_json

    if path.stat().st_size > limits.max_spec_bytes:
        raise SpecError(f"space: {over_limit('bytes', 'max_spec_bytes', limits)}")
    text = path.read_text(errors="replace")
    check_json_shape(text, "space", limits)
    check_design(space_from_json(text, "space"), spec, model)


def _answer(task: VetTask) -> dict[str, Any]:
    """Run :func:`vet` within the task's CPU time; turn the unexpected into an answer."""
    allow_cpu_seconds(task.cpu_seconds)
    try:
        return vet(task)
    except MemoryError:
        limit = memory_limit_mb()
        detail = f"checking the upload needs more than {limit} MB (FMUID_CHECK_MEMORY_MB)"
        return {"ok": False, "status": 422, "detail": detail, "recycle": True}
    except Exception as exc:  # a bug here must not end the process silently
        logger.exception("checking a submission failed")
        return {"ok": False, "status": 500, "detail": f"checking the upload failed: {exc!r}"}


def _resident_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _watch_parent(parent: int) -> None:
    """End this process once the service that started it is gone."""
    while os.getppid() == parent:
        time.sleep(0.5)
    end_tree(os.getpid())
    os._exit(1)


def main(argv: list[str]) -> int:
    """Answer tasks from stdin until it closes (or the parent dies, or memory piles up)."""
    limit_memory(int(argv[1]))
    answers = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)  # whatever else writes to stdout (native code) goes to the log
    if not become_subreaper():
        logger.warning("not a child subreaper: a process a probed FMU detaches may outlive it")
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True).start()
    answers.write(READY + "\n")
    answers.flush()
    for line in sys.stdin:
        answer = _answer(VetTask(**json.loads(line)))
        end_tree(os.getpid())  # what the probed binary left behind
        reap_children()
        recycle = answer.pop("recycle", False) or _resident_mb() > RECYCLE_RSS_MB
        answers.write(json.dumps(answer) + "\n")
        answers.flush()
        if recycle:
            return 0
    return 0


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s %(message)s")
    sys.exit(main(sys.argv))
