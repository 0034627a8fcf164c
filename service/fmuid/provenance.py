"""How a result was made: the ``provenance`` block of every result JSON.

One helper for every stage: :func:`record` stamps a result object (any frozen dataclass with a
``provenance`` field) with the fmuid version, the FMU's sha256, the seed, the options, the
spec's and the data's hashes, start and end time and the machine. The result's ``to_dict``
writes it under ``provenance`` (its schema: ``fmuid.estimation.schema.ProvenanceOut``);
:func:`fmuid.load_result` reads it back (:meth:`Provenance.from_dict`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import platform
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from fmuid.data import Experiment, Spec

R = TypeVar("R")

PACKAGES = ("fmpy", "numpy", "scipy", "pymoo")
"""Libraries whose versions change the numbers, recorded beside fmuid's."""


@dataclass(frozen=True)
class Provenance:
    """How a result was made.

    Attributes
    ----------
    fmuid_version
        The fmuid that computed it.
    fmu_sha256
        The FMU file's sha256.
    seed
        The seed of every random draw (the spec's ``seed``).
    options
        The stage's options (e.g. ``workers``, ``global_search``), as JSON values.
    spec_sha256
        sha256 of the spec as JSON (``Spec.model_dump_json``).
    data
        Per experiment: ``name`` and ``sha256``, of the file's bytes when ``name`` is a file
        that exists, else of the values (``of`` says which).
    started, finished
        UTC times, ISO 8601.
    machine
        ``cores``, ``platform``, ``python`` and the versions of :data:`PACKAGES`.

    """

    fmuid_version: str
    fmu_sha256: str
    seed: int | None
    options: dict[str, Any]
    spec_sha256: str
    data: tuple[dict[str, str], ...]
    started: str
    finished: str
    machine: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Provenance:
        """Read the JSON form back."""
        return cls(
            fmuid_version=str(data["fmuid_version"]),
            fmu_sha256=str(data["fmu_sha256"]),
            seed=None if data.get("seed") is None else int(data["seed"]),
            options=dict(data.get("options") or {}),
            spec_sha256=str(data.get("spec_sha256", "")),
            data=tuple(dict(d) for d in data.get("data") or ()),
            started=str(data["started"]),
            finished=str(data["finished"]),
            machine=dict(data.get("machine") or {}),
        )


def now() -> float:
    """Return the time a stage starts, for :func:`record` (seconds since the epoch)."""
    return time.time()


def record(
    result: R,
    *,
    fmu_sha256: str,
    spec: Spec,
    experiments: Sequence[Experiment] = (),
    options: Mapping[str, Any] | None = None,
    started: float,
    seed: int | None = None,
) -> R:
    """Return ``result`` with its provenance: what made it, from ``started`` until now.

    Parameters
    ----------
    result
        A frozen dataclass result with a ``provenance`` field (fit, profile, design, diagnosis).
    fmu_sha256
        The FMU's sha256 (``FmuModel.sha256``).
    spec
        The study's spec (its ``seed`` is the seed).
    experiments
        The data.
    options
        The stage's options, JSON values (a non-JSON value is written as its ``repr``).
    started
        :func:`now` when the stage began.
    seed
        The stage's seed when it is not the spec's (e.g. a design space's).

    """
    provenance = Provenance(
        fmuid_version=_version("fmuid"),
        fmu_sha256=fmu_sha256,
        seed=spec.seed if seed is None else seed,
        options={k: _json_value(v) for k, v in (options or {}).items()},
        spec_sha256=hashlib.sha256(spec.model_dump_json().encode()).hexdigest(),
        data=tuple(_data_hash(e) for e in experiments),
        started=_iso(started),
        finished=_iso(time.time()),
        machine=machine(),
    )
    return dataclasses.replace(result, provenance=provenance)  # type: ignore[type-var]


def read(data: Mapping[str, Any]) -> Provenance | None:
    """Return the provenance of a result's JSON form, or ``None`` when it has none."""
    block = data.get("provenance")
    return None if not block else Provenance.from_dict(block)


def machine() -> dict[str, Any]:
    """Return the machine's cores, platform, Python and library versions."""
    return {
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        **{name: _version(name) for name in PACKAGES},
    }


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "unknown"


def _iso(seconds: float) -> str:
    return datetime.fromtimestamp(seconds, UTC).isoformat(timespec="seconds")


def _data_hash(experiment: Experiment) -> dict[str, str]:
    path = Path(experiment.name)
    if path.is_file():
        return {"name": experiment.name, "sha256": _file_hash(path), "of": "file"}
    digest = hashlib.sha256(experiment.time.tobytes())
    for name in sorted(experiment.columns):
        digest.update(name.encode())
        digest.update(experiment.columns[name].tobytes())
    return {"name": experiment.name, "sha256": digest.hexdigest(), "of": "values"}


def _file_hash(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _json_value(value: Any) -> Any:
    if value is None or isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, Mapping):
        return {str(k): _json_value(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_value(v) for v in value]
    return repr(value)
