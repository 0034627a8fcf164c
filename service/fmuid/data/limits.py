"""Size limits of the input files, so that reading any file costs time linear in a bounded size.

:class:`InputLimits` bounds CSV files and specs, :class:`FmuLimits` the checks of an uploaded FMU
(:mod:`fmuid.intake.fmucheck`).

The defaults suit the CLI and the service alike; the service takes each from its ``FMUID_<NAME>``
setting (:class:`fmuid.settings.Settings`). A file over a limit is refused before or while it is
parsed, with a message naming the limit and the service's setting of it.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

__all__ = ["FmuLimits", "InputLimits", "over_limit"]


@dataclass(frozen=True)
class InputLimits:
    """Largest input files accepted.

    Attributes
    ----------
    max_csv_bytes
        Size of one CSV file [bytes].
    max_csv_rows
        Data rows of one CSV file.
    max_csv_columns
        Columns of one CSV file.
    max_cell_chars
        Characters of one CSV cell or column name (spaces included).
    max_spec_bytes
        Size of the spec [bytes].
    max_spec_keys
        Keys of all the spec's objects together.
    max_spec_depth
        Nesting of arrays and objects in the spec (a valid spec nests 4 deep).

    """

    max_csv_bytes: int = 50_000_000
    max_csv_rows: int = 200_000
    max_csv_columns: int = 1_000
    max_cell_chars: int = 1_000
    max_spec_bytes: int = 1_000_000
    max_spec_keys: int = 10_000
    max_spec_depth: int = 16

    def __post_init__(self) -> None:
        for field in fields(self):
            if getattr(self, field.name) < 1:
                raise ValueError(f"{field.name} must be at least 1")


@dataclass(frozen=True)
class FmuLimits:
    """Limits of the checks of an uploaded FMU (each a ``FMUID_<NAME>`` service setting).

    Attributes
    ----------
    max_fmu_unpacked_bytes
        Sum of the members' unpacked sizes [bytes].
    max_model_description_bytes
        Unpacked size of ``modelDescription.xml`` [bytes].
    max_model_variables
        Variables listed in ``modelDescription.xml``.
    probe_timeout_s
        Wall-clock time the binary may take to load [s].
    probe_memory_mb
        Address space of the process that loads the binary [MiB].

    """

    max_fmu_unpacked_bytes: int = 200 * 1024 * 1024
    max_model_description_bytes: int = 32 * 1024 * 1024
    max_model_variables: int = 100_000
    probe_timeout_s: float = 10.0
    probe_memory_mb: int = 1024


def over_limit(noun: str, field: str, limits: InputLimits) -> str:
    """Return ``"more than the limit of N <noun> (FMUID_<FIELD>)"`` for a refusal message."""
    return f"more than the limit of {getattr(limits, field)} {noun} (FMUID_{field.upper()})"
