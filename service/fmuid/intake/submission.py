"""Check a job submission completely, then store its files and queue it.

Everything a job needs is checked before it is queued, so a bad upload gets a 422 naming the
problem at once instead of a failed job later. Uploads are written to a private temporary folder
under their original names (experiment names come from the CSV file names); a checking process
(:mod:`fmuid.intake.pool`, :mod:`fmuid.intake.vet`) then checks the FMU, each CSV file (or a
design job's experiment space), the spec and how they fit together, so that no uploaded byte is
parsed in the service itself; the files move into the content-addressed blob store only once
they passed.
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import asdict, dataclass, replace
from pathlib import Path, PurePosixPath
from typing import BinaryIO

from fmuid.errors import FmuidError, SpecError
from fmuid.intake.pool import VettingPool
from fmuid.intake.vet import VetTask
from fmuid.jobs.kinds import runner
from fmuid.jobs.records import TEST_DATA, Kind
from fmuid.jobs.store import Dataset, Job, JobStore
from fmuid.model.builtin import BUILTIN_MODELS, builtin_fmu
from fmuid.settings import Settings

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
        raise SubmissionError(422, f"{field}: {filename[:300]!r} is not an acceptable file name")
    return name


def _save(upload: Upload, target: Path) -> None:
    with open(target, "wb") as out:
        shutil.copyfileobj(upload.file, out, 1 << 20)


def _place_fmu(workdir: Path, fmu: Upload | None, model: str | None) -> tuple[str, str | None]:
    """Put the FMU into ``workdir``; return its file name and its uploaded name (None: built-in)."""
    if (fmu is None) == (model is None):
        raise SubmissionError(422, "give exactly one of 'fmu' (a .fmu file) or 'model' (a name)")
    if model is not None:
        if model not in BUILTIN_MODELS:
            known = ", ".join(sorted(BUILTIN_MODELS))
            raise SubmissionError(
                422, f"model: unknown built-in model {model[:100]!r}; known: {known}"
            )
        try:
            source = builtin_fmu(model)
        except FmuidError as exc:
            raise SubmissionError(503, f"built-in model {model!r} is not available: {exc}") from exc
        shutil.copyfile(source, workdir / f"{model}.fmu")
        return f"{model}.fmu", None
    assert fmu is not None
    name = safe_name(fmu.filename, "fmu")
    _save(fmu, workdir / "upload.fmu")
    return "upload.fmu", name


def submit(
    store: JobStore,
    pool: VettingPool,
    settings: Settings,
    kind: Kind,
    spec: str,
    data: list[Upload],
    fmu: Upload | None,
    model: str | None,
    space: Upload | None = None,
    test_data: list[Upload] | None = None,
) -> Job:
    """Check a submission in a checking process and queue its job (blocking).

    Parameters
    ----------
    store
        Where the files and the job go.
    pool
        The checking processes.
    settings
        The limits of the checks.
    kind
        ``"fit"``, ``"profile"``, ``"diagnose"`` or ``"design"`` (:mod:`fmuid.jobs.kinds`).
    spec
        The study specification (JSON text).
    data
        The CSV files, one per experiment.
    fmu, model
        An uploaded FMU or the name of a built-in one (exactly one of them).
    space
        The experiment space JSON (kind ``"design"``, which takes no data).
    test_data
        Held-out CSV files (not for ``"design"``), checked like ``data`` and stored as datasets
        named ``test_data/<name>``.

    Returns
    -------
    Job
        The queued job.

    Raises
    ------
    SubmissionError
        With status 422 naming the problem (unknown kind, bad FMU, CSV, spec, a mismatch between
        them or a limit), or 503 when a built-in model is missing.

    """
    test_data = test_data or []
    try:
        takes_space = runner(kind).takes_space
    except SpecError as exc:
        raise SubmissionError(422, str(exc)) from exc
    if takes_space:
        if test_data:
            raise SubmissionError(422, f"test_data: kind {kind!r} takes no test data")
        return _submit_space(store, pool, settings, kind, spec, data, space, fmu, model)
    if space is not None:
        raise SubmissionError(422, f"space: only kind 'design' takes a space, not {kind!r}")
    if not data:
        raise SubmissionError(422, "data: give at least one CSV file")
    names = [safe_name(upload.filename, "data") for upload in data]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise SubmissionError(422, f"data: file names must differ; repeated: {duplicates}")
    test_names = [safe_name(upload.filename, TEST_DATA) for upload in test_data]
    duplicates = sorted({n for n in test_names if test_names.count(n) > 1})
    if duplicates:
        raise SubmissionError(422, f"{TEST_DATA}: file names must differ; repeated: {duplicates}")
    with tempfile.TemporaryDirectory(dir=store.tmp_dir()) as tmp:
        workdir = Path(tmp)
        (workdir / "data").mkdir()
        (workdir / TEST_DATA).mkdir()
        (workdir / "spec.json").write_text(spec, encoding="utf-8", errors="replace")
        paths = [workdir / "data" / name for name in names]
        test_paths = [workdir / TEST_DATA / name for name in test_names]
        for upload, path in zip([*data, *test_data], [*paths, *test_paths], strict=True):
            _save(upload, path)
        fmu_file, fmu_name = _place_fmu(workdir, fmu, model)
        task = _task(workdir, names, fmu_file, fmu_name, settings)
        answer = pool.check(replace(task, test_names=test_names))
        if not answer["ok"]:
            raise SubmissionError(answer["status"], answer["detail"])
        fmu_sha = store.add_file(workdir / fmu_file)
        datasets = [Dataset(name, store.add_file(path)) for name, path in zip(names, paths)]
        datasets += [
            Dataset(f"{TEST_DATA}/{name}", store.add_file(path))
            for name, path in zip(test_names, test_paths)
        ]
    return store.create(kind, spec, fmu_sha, answer["model_name"], datasets)


def _submit_space(
    store: JobStore,
    pool: VettingPool,
    settings: Settings,
    kind: Kind,
    spec: str,
    data: list[Upload],
    space: Upload | None,
    fmu: Upload | None,
    model: str | None,
) -> Job:
    """Check and queue a design job: its space is stored in the job's ``space`` column.

    The text stored is the text checked (undecodable bytes replaced in both).
    """
    if data:
        raise SubmissionError(422, f"data: kind {kind!r} takes a 'space' file, not data")
    if space is None:
        raise SubmissionError(422, f"space: kind {kind!r} needs the experiment space (E.json)")
    with tempfile.TemporaryDirectory(dir=store.tmp_dir()) as tmp:
        workdir = Path(tmp)
        (workdir / "spec.json").write_text(spec, encoding="utf-8", errors="replace")
        space_path = workdir / "space.json"
        _save(space, space_path)
        fmu_file, fmu_name = _place_fmu(workdir, fmu, model)
        answer = pool.check(_task(workdir, [], fmu_file, fmu_name, settings, space_path.name))
        if not answer["ok"]:
            raise SubmissionError(answer["status"], answer["detail"])
        fmu_sha = store.add_file(workdir / fmu_file)
        text = space_path.read_text(errors="replace")
    return store.create(kind, spec, fmu_sha, answer["model_name"], [], space=text)


def _task(
    workdir: Path,
    data_names: list[str],
    fmu_file: str,
    fmu_name: str | None,
    settings: Settings,
    space_file: str | None = None,
) -> VetTask:
    """Return the checking process's task for the files in ``workdir``, under the limits."""
    return VetTask(
        workdir=str(workdir),
        data_names=data_names,
        fmu_file=fmu_file,
        fmu_name=fmu_name,
        cpu_seconds=settings.check_timeout_s,
        input_limits=asdict(settings.input_limits),
        fmu_limits=asdict(settings.fmu_limits),
        space_file=space_file,
    )
