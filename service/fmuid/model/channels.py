"""Variables set or read together, grouped by their FMI get/set function and C type."""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from typing import Any

import numpy as np

from fmuid.errors import FmuError
from fmuid.model.fmu import Variable

_C_INT = ctypes.c_int
_FMI2_TYPES: dict[str, tuple[str, Any]] = {
    "Real": ("Real", ctypes.c_double),
    "Integer": ("Integer", _C_INT),
    "Enumeration": ("Integer", _C_INT),
    "Boolean": ("Boolean", _C_INT),
    "String": ("String", ctypes.c_char_p),
}
_FMI3_TYPES: dict[str, tuple[str, Any]] = {
    "Float64": ("Float64", ctypes.c_double),
    "Float32": ("Float32", ctypes.c_float),
    "Int8": ("Int8", ctypes.c_int8),
    "UInt8": ("UInt8", ctypes.c_uint8),
    "Int16": ("Int16", ctypes.c_int16),
    "UInt16": ("UInt16", ctypes.c_uint16),
    "Int32": ("Int32", ctypes.c_int32),
    "UInt32": ("UInt32", ctypes.c_uint32),
    "Int64": ("Int64", ctypes.c_int64),
    "UInt64": ("UInt64", ctypes.c_uint64),
    "Enumeration": ("Int64", ctypes.c_int64),
    "Boolean": ("Boolean", ctypes.c_bool),
    "String": ("String", ctypes.c_char_p),
}


class Channels:
    """Variables set or read together, grouped by their FMI get/set function.

    Parameters
    ----------
    variables
        The variables, in the order of the values passed to :meth:`Instance.set`.
    version
        ``"2.0"`` or ``"3.0"``.

    """

    def __init__(self, variables: Sequence[Variable], version: str) -> None:
        table = _FMI2_TYPES if version == "2.0" else _FMI3_TYPES
        prefix = "fmi2" if version == "2.0" else "fmi3"
        groups: dict[str, list[int]] = {}
        for i, v in enumerate(variables):
            if v.type not in table or v.shape:
                raise FmuError(
                    f"variable {v.name!r} has type {v.type_label}, which fmuid cannot use"
                )
            groups.setdefault(table[v.type][0], []).append(i)
        self.version = version
        self.variables = list(variables)
        self.size = len(variables)
        self.groups: list[tuple[str, list[int], Any, Any]] = []
        for suffix, index in groups.items():
            ctype = table[variables[index[0]].type][1]
            refs = (ctypes.c_uint * len(index))(*(variables[i].value_reference for i in index))
            self.groups.append((suffix, index, refs, (ctype * len(index))()))
        self.all_float = len(self.groups) == 1 and self.groups[0][0] in ("Real", "Float64")
        self.refs = self.groups[0][2] if self.all_float else (ctypes.c_uint * 0)()
        self.buffer = self.groups[0][3] if self.all_float else (ctypes.c_double * 0)()
        self.view = np.ctypeslib.as_array(self.buffer) if self.size else np.empty(0)
        self.values = np.empty(self.size)
        self.setters = [f"{prefix}Set{group[0]}" for group in self.groups]
        self.getters = [f"{prefix}Get{group[0]}" for group in self.groups]

        self.continuous = [i for i, v in enumerate(variables) if v.is_continuous]
        """Indices of the variables that are linear between samples (continuous floats)."""
        self.helpers: dict[str, Any] = {}
        """Per-channel-set objects the masters build once (buffers of derivatives, subsets)."""

    def subset(self, index: Sequence[int]) -> Channels:
        """Return the channels of the variables at ``index`` (made once, then cached)."""
        key = "subset" + ",".join(map(str, index))
        found = self.helpers.get(key)
        if found is None:
            found = self.helpers[key] = Channels([self.variables[i] for i in index], self.version)
        return found


def to_c(variable: Variable, value: float | str | bool) -> Any:
    """Convert a value to what the FMI setter of ``variable``'s type takes.

    Raises
    ------
    FmuError
        Naming the variable and its type when the value does not fit it.

    """
    kind = variable.kind
    if kind == "string":
        if not isinstance(value, str):
            raise FmuError(f"{variable.name!r} is a String; give it a text value, not {value!r}")
        return value.encode()
    if isinstance(value, str):
        raise FmuError(f"{variable.name!r} is {variable.type_label}; got the text {value!r}")
    if isinstance(value, bool) and kind != "boolean":
        raise FmuError(f"{variable.name!r} is {variable.type_label}; got the Boolean {value!r}")
    number = float(value)
    if kind == "float":
        return number
    if kind == "boolean" and number not in (0.0, 1.0):
        raise FmuError(f"{variable.name!r} is Boolean; it takes 0 or 1 (false/true), not {value!r}")
    if number != round(number):
        raise FmuError(
            f"{variable.name!r} is {variable.type_label}; it takes whole numbers, not {value!r}"
        )
    return int(number)
