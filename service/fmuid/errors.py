"""Exception hierarchy of fmuid.

Every message names the file, field, row, column or FMI function at fault, so that a user can
fix the input without reading a traceback. The CLI maps ``DataError``/``SpecError``/``FmuError``
raised while loading inputs to exit status 2 and the HTTP API maps them to 4xx responses.
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
