"""A stored job's inputs, staged as files and loaded: one loader for the job and its report."""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from pathlib import Path

from fmuid.jobs.kinds import JobInputs, runner
from fmuid.jobs.records import TEST_DATA
from fmuid.jobs.store import Job, JobStore


def stage_inputs(store: JobStore, job: Job, workdir: Path) -> tuple[Path, list[Path]]:
    """Give the job's FMU and CSV blobs their file names back; return their paths.

    Experiment names come from the CSV file names, so each CSV is linked into ``workdir`` under
    its uploaded name. The FMU gets a stable path, ``<data_dir>/fmus/<sha256>/<model>.fmu``,
    because dask workers open it by path: on other machines they see it when the data folder is
    shared (the compose file mounts the same volume).
    """
    fmu_dir = store.layout.fmu_dir(job.fmu_sha256)
    fmu_dir.mkdir(parents=True, exist_ok=True)
    fmu = fmu_dir / (re.sub(r"[^A-Za-z0-9_-]", "_", job.model_name)[:100] + ".fmu")
    if not fmu.exists():
        link = fmu_dir / f".{os.getpid()}.tmp"
        link.unlink(missing_ok=True)
        link.symlink_to(store.blob_path(job.fmu_sha256))
        os.replace(link, fmu)
    data_dir = workdir / "data"
    (data_dir / TEST_DATA).mkdir(parents=True)
    paths = []
    for dataset in job.datasets:
        path = data_dir / dataset.name
        path.symlink_to(store.blob_path(dataset.sha256))
        paths.append(path)
    return fmu, paths


def load_job_inputs(
    store: JobStore, job: Job, workdir: Path, on_staged: Callable[[Path], None] | None = None
) -> JobInputs:
    """Stage the job's files in ``workdir`` and parse its spec, held-out data and kind's inputs.

    ``on_staged`` is called with the FMU's path once the files are staged, before anything is
    parsed. What the kind reads besides (experiments, or a design's space) is its runner's
    ``load`` (:mod:`fmuid.jobs.kinds`).

    Raises
    ------
    SpecError
        If the job's kind is unknown (before anything is staged), or its spec or space is bad.

    """
    from fmuid.data import load_experiment, spec_from_json

    kind = runner(job.kind)
    fmu, paths = stage_inputs(store, job, workdir)
    if on_staged is not None:
        on_staged(fmu)
    spec = spec_from_json(job.spec, "spec")
    tests = [load_experiment(p) for p in paths if p.parent.name == TEST_DATA]
    data = [p for p in paths if p.parent.name != TEST_DATA]
    return kind.load(JobInputs(fmu, spec, [], tests), job, data)
