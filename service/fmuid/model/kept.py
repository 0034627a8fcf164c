"""Per-process caches: values kept by key (the content or the ids of arrays), or per live object."""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable, Hashable
from typing import Any, Generic, TypeVar, cast

import numpy as np

V = TypeVar("V")
T = TypeVar("T")


def content_key(*arrays: np.ndarray) -> tuple[tuple[int, ...], bytes]:
    """Return a cache key of float arrays: their sizes and a digest of their values."""
    digest = hashlib.blake2b(digest_size=16)
    for a in arrays:
        digest.update(np.ascontiguousarray(a, dtype=float).tobytes())
    return tuple(np.size(a) for a in arrays), digest.digest()


MAX_BYTES = 256 * 2**20
"""Array bytes one cache keeps at most (the newest value is kept whatever its size)."""


class Kept(Generic[V]):
    """The last ``size`` values made, by key, within :data:`MAX_BYTES`; the oldest go first.

    A fit simulates the same times and inputs many times; what depends on them alone is made
    once. Callers keep what they get unchanged (arrays are made read-only by the maker). The
    byte bound matters on long records on a fine grid: a 25,000-sample record at 64 steps per
    sample makes grids of 1.6 million points, and sixteen of them would hold gigabytes in
    every worker process.
    """

    def __init__(self, size: int, max_bytes: int = MAX_BYTES) -> None:
        self.size = size
        self.max_bytes = max_bytes
        self._values: dict[Hashable, tuple[V, int]] = {}

    def get(
        self, key: Hashable, make: Callable[[], V], valid: Callable[[V], bool] | None = None
    ) -> V:
        """Return the value kept for ``key``, made by ``make()`` the first time.

        A kept value for which ``valid`` is false is made again and replaces it as the newest
        (a key by arrays' ids, whose contents may have changed in place since).
        """
        kept = self._values.get(key)
        if kept is not None:
            if valid is None or valid(kept[0]):
                return kept[0]
            del self._values[key]
        value = make()
        self._values[key] = (value, array_bytes(value))
        while len(self._values) > 1 and (
            len(self._values) > self.size
            or sum(b for _, b in self._values.values()) > self.max_bytes
        ):
            self._values.pop(next(iter(self._values)))
        return value


class PerObject:
    """Values made once per live object, by its identity (an experiment of a study, say).

    Kept by ``(kind, id(obj))`` together with the object, so that a new object at the id of a
    dead one is not taken for it. What it holds is per process: it pickles empty.
    """

    def __init__(self) -> None:
        self._values: dict[tuple[Hashable, int], tuple[object, Any]] = {}

    def __reduce__(self) -> tuple[type[PerObject], tuple[()]]:
        return PerObject, ()

    def get(self, obj: object, make: Callable[[], T], kind: Hashable = None) -> T:
        """Return the ``kind`` value of ``obj``, made by ``make()`` the first time."""
        key = (kind, id(obj))
        kept = self._values.get(key)
        if kept is None or kept[0] is not obj:
            kept = (obj, make())
            self._values[key] = kept
        return cast(T, kept[1])


def array_bytes(value: object) -> int:
    """Bytes of the arrays in ``value`` (an array, a tuple or list of them, or a dataclass)."""
    if isinstance(value, np.ndarray):
        return value.nbytes
    if isinstance(value, tuple | list):
        return sum(array_bytes(v) for v in value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return sum(array_bytes(getattr(value, f.name)) for f in dataclasses.fields(value))
    return 0


def read_only(a: np.ndarray) -> np.ndarray:
    """Return ``a`` flagged read-only (a kept array is shared by every caller)."""
    a.setflags(write=False)
    return a
