"""Where a study starts: the spec's start values, an SSP file's, or an earlier fit's estimates.

Used by the CLI's ``--start`` and by ``fmuid.diagnose(..., start=...)``.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmuid.errors import DataError

if TYPE_CHECKING:
    from fmuid.data import Spec

logger = logging.getLogger(__name__)

Start = str | Path | Mapping[str, Any] | Any
"""What a study may start from: an ``.ssv`` or result ``.json`` path, a result's JSON (a
mapping) or a fit or profile result object."""


def start_at(spec: Spec, start: Start | None) -> Spec:
    """Return ``spec`` started at ``start`` (``spec`` itself when ``start`` is None).

    Parameters
    ----------
    spec
        The study.
    start
        An SSP parameter-value file (``.ssv``: its values, the global search as the spec says);
        or an earlier fit or profile result: its JSON file, its JSON (a mapping) or the
        ``FitResult``/``ProfileResult`` itself. A result gives its estimates as start values
        and turns the global search off (the refinement starts there).

    Raises
    ------
    DataError
        If a file cannot be read or is not a fit or profile result.
    SpecError
        If a value is not a number or lies outside its parameter's bounds.

    """
    from fmuid.formats.ssv import read_ssv, with_start_values

    if start is None or start == "":
        return spec
    if isinstance(start, str | Path) and not str(start).lower().endswith(".json"):
        return with_start_values(spec, read_ssv(str(start)).values, str(start))
    estimates, source = _estimates(start)
    logger.info("starting at the estimates of %s (no global search)", source)
    spec = with_start_values(spec, estimates, source)
    return spec.model_copy(update={"global_search": False})


def _estimates(start: Start) -> tuple[dict[str, float], str]:
    """Return the parameter estimates of a result (file, JSON or object) and what it is."""
    fit = getattr(start, "fit", start)  # a ProfileResult holds its fit
    if hasattr(fit, "estimates"):
        return {n: float(v) for n, v in fit.estimates.items()}, f"an earlier {type(start).__name__}"
    source = "the given result"
    if isinstance(start, str | Path):
        source = str(start)
        try:
            start = json.loads(Path(start).read_text())
        except (OSError, ValueError) as exc:
            raise DataError(f"{source}: not a readable result JSON: {exc}") from exc
    params = start.get("parameters") if isinstance(start, Mapping) else None
    if not isinstance(params, Mapping) or not all(
        isinstance(p, Mapping) and "estimate" in p for p in params.values()
    ):
        raise DataError(f"{source}: not a fit or profile result (no parameter estimates)")
    return {n: p["estimate"] for n, p in params.items()}, source
