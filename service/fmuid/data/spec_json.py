"""Read a study specification from JSON text: limits first, then syntax, then content.

:func:`load_spec` and :func:`spec_from_json` turn the text into a validated
:class:`~fmuid.data.spec.Spec`; every problem becomes one line of a
:class:`~fmuid.errors.SpecError` naming the source and the field path. Before the text is parsed,
its size is checked; once it is parsed (in time linear in its size), one pass checks its nesting
depth and number of keys against :class:`~fmuid.data.limits.InputLimits` before pydantic or any
message builder sees it.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, get_args, get_origin

from pydantic import ValidationError

from fmuid.data.limits import InputLimits, over_limit
from fmuid.data.messages import capped, show, suggest
from fmuid.data.spec import Spec
from fmuid.errors import SpecError

__all__ = ["load_spec", "spec_from_json"]


def load_spec(path: str | os.PathLike[str], limits: InputLimits | None = None) -> Spec:
    """Read and validate a spec file (JSON, UTF-8).

    Parameters
    ----------
    path
        The JSON file.
    limits
        Largest size, key count and nesting accepted (default :class:`InputLimits`).

    Returns
    -------
    Spec
        The validated spec; its :attr:`Spec.source` is the file's base name.

    Raises
    ------
    SpecError
        Naming the file and, one line per problem, the field path at fault.

    """
    limits = limits or InputLimits()
    path = Path(path)
    try:
        with path.open("rb") as stream:
            raw = stream.read(limits.max_spec_bytes + 1)
    except FileNotFoundError:
        raise SpecError(f"{path.name}: file not found ({path})") from None
    except OSError as error:
        raise SpecError(f"{path.name}: cannot read the file ({error.strerror})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise SpecError(f"{path.name}: not UTF-8 text (byte {error.start})") from None
    return spec_from_json(text, source=path.name, limits=limits)


def spec_from_json(text: str, source: str = "spec", limits: InputLimits | None = None) -> Spec:
    """Validate a spec given as JSON text.

    Parameters
    ----------
    text
        The JSON document.
    source
        Name used in error messages and kept as :attr:`Spec.source` (the file name).
    limits
        Largest size, key count and nesting accepted (default :class:`InputLimits`).

    Returns
    -------
    Spec
        The validated spec.

    Raises
    ------
    SpecError
        For a text over a limit, invalid JSON (with line and column) or invalid content (one
        line per problem, each naming the field path).

    """
    if not text.strip():
        raise SpecError(f"{source}: file is empty")
    limits = limits or InputLimits()
    if len(text.encode("utf-8", errors="replace")) > limits.max_spec_bytes:
        raise SpecError(f"{source}: {over_limit('bytes', 'max_spec_bytes', limits)}")

    def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        data = dict(pairs)
        if len(data) < len(pairs):
            seen: set[str] = set()
            for key, _ in pairs:
                if key in seen:
                    raise SpecError(f"{source}: key '{key}' appears twice in one object")
                seen.add(key)
        return data

    try:
        data = json.loads(text, object_pairs_hook=unique_keys)
    except json.JSONDecodeError as error:
        raise SpecError(
            f"{source}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}"
        ) from None
    except RecursionError:
        what = over_limit("nested arrays and objects", "max_spec_depth", limits)
        raise SpecError(f"{source}: {what}") from None
    _check_shape(data, source, limits)
    if not isinstance(data, dict):
        kinds = {list: "an array", str: "a string", bool: "a boolean", type(None): "null"}
        kind = kinds.get(type(data), "a number")
        raise SpecError(f"{source}: the spec must be a JSON object, got {kind}")
    try:
        spec = Spec.model_validate(data)
    except ValidationError as error:
        raise SpecError(_format_errors(source, error)) from None
    spec._source = source
    return spec


def _format_errors(source: str, error: ValidationError) -> str:
    """One line ``source: field.path: problem`` per pydantic error."""
    lines = []
    for item in error.errors(include_url=False):
        loc: list[str | int] = list(item["loc"])
        context = item.get("ctx") or {}
        if "field" in context:
            loc += [int(p) if p.isdigit() else p for p in str(context["field"]).split(".")]
        if item["type"] == "extra_forbidden":
            message = _unknown_field(loc)
        elif item["type"] == "missing":
            message = "required field is missing"
        elif item["type"] == "spec":
            message = item["msg"]
        else:
            message = f"{item['msg']} (got {show(item['input'])})"
        lines.append(f"{source}: {_path(loc)}: {message}")
    return capped(lines)


def _check_shape(data: Any, source: str, limits: InputLimits) -> None:
    """Refuse parsed JSON nested deeper or holding more keys than the limits allow."""
    keys = 0
    level = [data]
    for depth in range(1, limits.max_spec_depth + 2):
        inner: list[Any] = []
        for item in level:
            if isinstance(item, dict):
                keys += len(item)
                inner += item.values()
            elif isinstance(item, list):
                inner += item
        if keys > limits.max_spec_keys:
            raise SpecError(f"{source}: {over_limit('keys', 'max_spec_keys', limits)}")
        level = [item for item in inner if isinstance(item, dict | list)]
        if not level:
            return
        if depth == limits.max_spec_depth:
            what = over_limit("nested arrays and objects", "max_spec_depth", limits)
            raise SpecError(f"{source}: {what}")


def _path(loc: Sequence[str | int]) -> str:
    """Render a location as ``parameters.C_atf.lower`` / ``inputs[0]``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else f".{part}"
    return text.lstrip(".") or "(top level)"


def _unknown_field(loc: Sequence[str | int]) -> str:
    """Explain an unknown key, suggesting the allowed field names."""
    annotation: Any = Spec
    for part in loc[:-1]:
        if get_origin(annotation) in (dict, list):
            annotation = get_args(annotation)[-1]
        else:
            annotation = annotation.model_fields[part].annotation
    allowed = list(annotation.model_fields)
    return f"unknown field{suggest(str(loc[-1]), allowed, 'fields')}"
