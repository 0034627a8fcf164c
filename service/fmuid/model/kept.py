"""Values kept by the content of the arrays they were made from (per-process caches)."""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

import numpy as np

V = TypeVar("V")


def content_key(*arrays: np.ndarray) -> tuple[tuple[int, ...], bytes]:
    """Return a cache key of float arrays: their sizes and a digest of their values."""
    digest = hashlib.blake2b(digest_size=16)
    for a in arrays:
        digest.update(np.ascontiguousarray(a, dtype=float).tobytes())
    return tuple(np.size(a) for a in arrays), digest.digest()


class Kept(Generic[V]):
    """The last ``size`` values made, by key; the oldest is dropped first.

    A fit simulates the same times and inputs many times; what depends on them alone is made
    once. Callers keep what they get unchanged (arrays are made read-only by the maker).
    """

    def __init__(self, size: int) -> None:
        self.size = size
        self._values: dict[Hashable, V] = {}

    def get(self, key: Hashable, make: Callable[[], V]) -> V:
        """Return the value kept for ``key``, made by ``make()`` the first time."""
        value = self._values.get(key)
        if value is None:
            value = self._values[key] = make()
            if len(self._values) > self.size:
                self._values.pop(next(iter(self._values)))
        return value


def read_only(a: np.ndarray) -> np.ndarray:
    """Return ``a`` flagged read-only (a kept array is shared by every caller)."""
    a.setflags(write=False)
    return a
