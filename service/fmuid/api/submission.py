"""Check a job submission completely, then store its files and queue it.

Everything a job needs is checked before it is queued, so a bad upload gets a 422 naming the
problem at once instead of a failed job later: the FMU (:mod:`fmuid.jobs.fmucheck`), each CSV
file (:func:`fmuid.data.load_experiment`), the spec (:func:`fmuid.data.spec_from_json`) and how
they fit together (:func:`fmuid.data.check_against_model`). Uploads are written to a private
temporary folder under their original names (experiment names come from the CSV file names) and
move into the content-addressed blob store only once they passed.
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import BinaryIO

from fmuid.data import Spec, check_against_model, load_experiment, spec_from_json
from fmuid.errors import FmuidError
from fmuid.jobs.fmucheck import check_fmu
from fmuid.jobs.store import Dataset, Job, JobStore
from fmuid.model.builtin import BUILTIN_MODELS, builtin_fmu
from fmuid.model.fmu import FmuModel

MAX_NAME_LENGTH = 200


class SubmissionError(Exception):
    """A submission that cannot be queued: ``status_code`` is the HTTP status to answer."""

    def __init__(self, status_code: int, message: str):
        super().__init__(message)
        self.status_code = status_code


@dataclass(frozen=True)
class Upload:
    """One uploaded file: the name the client gave and its content."""

    filename: str | None
    file: BinaryIO


def safe_name(filename: str | None, field: str) -> str:
    """Return the base name of an uploaded file, refusing names that cannot be a file name."""
    if not filename:
        raise SubmissionError(422, f"{field}: every file needs a file name")
    name = PurePosixPath(filename.replace("\\", "/")).name
    if (
        not name
        or name.startswith(".")
        or len(name) > MAX_NAME_LENGTH
        or any(ord(c) < 32 for c in name)
    ):
        raise SubmissionError(422, f"{field}: {filename!r} is not an acceptable file name")
    return name


def _save(upload: Upload, target: Path) -> None:
    with open(target, "wb") as out:
        shutil.copyfileobj(upload.file, out, 1 << 20)


def _load_fmu(
    workdir: Path, fmu: Upload | None, model: str | None, max_unpacked: int
) -> tuple[Path, FmuModel]:
    if (fmu is None) == (model is None):
        raise SubmissionError(422, "give exactly one of 'fmu' (a .fmu file) or 'model' (a name)")
    if model is not None:
        if model not in BUILTIN_MODELS:
            known = ", ".join(sorted(BUILTIN_MODELS))
            raise SubmissionError(422, f"model: unknown built-in model {model!r}; known: {known}")
        try:
            source = builtin_fmu(model)
        except FmuidError as exc:
            raise SubmissionError(503, f"built-in model {model!r} is not available: {exc}") from exc
        path = workdir / f"{model}.fmu"
        shutil.copyfile(source, path)
        return path, FmuModel(path)
    assert fmu is not None
    name = safe_name(fmu.filename, "fmu")
    path = workdir / "upload.fmu"
    _save(fmu, path)
    return path, check_fmu(path, name, max_unpacked)


def submit(
    store: JobStore,
    kind: str,
    spec: str,
    data: list[Upload],
    fmu: Upload | None,
    model: str | None,
    max_fmu_unpacked_bytes: int,
    space: Upload | None = None,
) -> Job:
    """Check a submission and queue its job.

    Parameters
    ----------
    store
        Where the files and the job go.
    kind
        ``"fit"``, ``"profile"``, ``"diagnose"`` or ``"design"``.
    spec
        The study specification (JSON text).
    data
        The CSV files, one per experiment.
    fmu, model
        An uploaded FMU or the name of a built-in one (exactly one of them).
    max_fmu_unpacked_bytes
        Largest accepted unpacked size of an uploaded FMU [bytes].
    space
        The experiment space JSON (kind ``"design"``, which takes no data).

    Returns
    -------
    Job
        The queued job.

    Raises
    ------
    SubmissionError
        With status 422 naming the problem (bad FMU, CSV, spec or a mismatch between them).

    """
    try:
        parsed_spec = spec_from_json(spec, "spec")
    except FmuidError as exc:
        raise SubmissionError(422, str(exc)) from exc
    if kind == "design":
        return _submit_design(
            store, spec, parsed_spec, data, space, fmu, model, max_fmu_unpacked_bytes
        )
    if space is not None:
        raise SubmissionError(422, f"space: only kind 'design' takes a space, not {kind!r}")
    if not data:
        raise SubmissionError(422, "data: give at least one CSV file")
    names = [safe_name(upload.filename, "data") for upload in data]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise SubmissionError(422, f"data: file names must differ; repeated: {duplicates}")
    with tempfile.TemporaryDirectory(dir=store.tmp_dir()) as tmp:
        workdir = Path(tmp)
        (workdir / "data").mkdir()
        paths = [workdir / "data" / name for name in names]
        for upload, path in zip(data, paths, strict=True):
            _save(upload, path)
        try:
            fmu_path, fmu_model = _load_fmu(workdir, fmu, model, max_fmu_unpacked_bytes)
            wrong_interface = fmu_model.interface_problem(parsed_spec.interface)
            if wrong_interface:
                raise SubmissionError(422, f"spec: interface: {wrong_interface}")
            experiments = [load_experiment(path) for path in paths]
            check_against_model(
                parsed_spec,
                fmu_model.parameters,
                fmu_model.inputs,
                fmu_model.outputs,
                experiments,
            )
        except FmuidError as exc:
            raise SubmissionError(422, str(exc)) from exc
        fmu_sha = store.add_file(fmu_path)
        datasets = [Dataset(name, store.add_file(path)) for name, path in zip(names, paths)]
    return store.create(kind, spec, fmu_sha, fmu_model.model_name, datasets)


def _submit_design(
    store: JobStore,
    spec: str,
    parsed_spec: Spec,
    data: list[Upload],
    space: Upload | None,
    fmu: Upload | None,
    model: str | None,
    max_fmu_unpacked_bytes: int,
) -> Job:
    """Check and queue a design job: the space is stored as its one dataset, ``space.json``."""
    from fmuid.design.space import check_design, space_from_json

    if data:
        raise SubmissionError(422, "data: kind 'design' takes a 'space' file, not data")
    if space is None:
        raise SubmissionError(422, "space: kind 'design' needs the experiment space (E.json)")
    with tempfile.TemporaryDirectory(dir=store.tmp_dir()) as tmp:
        workdir = Path(tmp)
        space_path = workdir / "space.json"
        _save(space, space_path)
        try:
            fmu_path, fmu_model = _load_fmu(workdir, fmu, model, max_fmu_unpacked_bytes)
            parsed = space_from_json(space_path.read_text(errors="replace"), "space")
            check_design(parsed, parsed_spec, fmu_model)
        except FmuidError as exc:
            raise SubmissionError(422, str(exc)) from exc
        fmu_sha = store.add_file(fmu_path)
        datasets = [Dataset("space.json", store.add_file(space_path))]
    return store.create("design", spec, fmu_sha, fmu_model.model_name, datasets)
