"""Exception hierarchy of fmuid.

Every message names the file, field, row, column or FMI function at fault, so that a user can
fix the input without reading a traceback. Each class is one cause, and the CLI gives each cause
its own exit status (:mod:`fmuid.cli`): bad input (``DataError``, ``SpecError``, ``FmuError``: an
FMU that cannot be used) 2, a fit the FMU failed at every trial point (``FitError``) 3, a failed
build of an FMU or of the native loop (``BuildError``: the toolchain) 4, anything else 1. The HTTP
API answers the bad-input classes found while checking an upload with 4xx responses.
"""

from __future__ import annotations


class FmuidError(Exception):
    """Base class of every error fmuid raises on purpose."""


class DataError(FmuidError, ValueError):
    """A dataset (CSV file) is malformed: the message names file, row and column."""


class SpecError(FmuidError, ValueError):
    """A study specification (JSON) is malformed: the message names the field."""


class FmuError(FmuidError):
    """An FMU could not be loaded or an FMI call failed.

    Parameters
    ----------
    message
        What went wrong, naming the FMU.
    function
        The FMI function that failed (e.g. ``fmi2DoStep``), if any.
    status
        The FMI status it returned (e.g. ``fmi2Error``), if any.
    """

    def __init__(self, message: str, function: str | None = None, status: str | None = None):
        super().__init__(message)
        self.function = function
        self.status = status


class FitError(FmuidError):
    """A fit found no solution: the FMU failed at every trial point or from every start."""


class BuildError(FmuidError):
    """The toolchain failed: gcc is missing or cannot compile an FMU or the native loop."""
