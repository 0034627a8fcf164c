"""Per-process caches keep a bounded number of values and of array bytes."""

from __future__ import annotations

import pickle
from dataclasses import dataclass

import numpy as np

from fmuid.model.kept import Kept, PerObject, array_bytes


@dataclass(frozen=True)
class _Pair:
    a: np.ndarray
    b: np.ndarray


def test_bytes_are_counted_through_tuples_and_dataclasses() -> None:
    pair = _Pair(np.zeros(10), np.zeros(5, dtype=np.int32))
    assert array_bytes(pair) == 80 + 20
    assert array_bytes((pair, [np.zeros(3)], "text")) == 100 + 24


def test_the_oldest_go_first_when_the_bytes_run_over() -> None:
    kept: Kept[np.ndarray] = Kept(16, max_bytes=3 * 800)
    made = []
    for k in range(5):
        kept.get(k, lambda k=k: made.append(k) or np.full(100, float(k)))
    assert made == [0, 1, 2, 3, 4]
    kept.get(4, lambda: made.append("again") or np.zeros(100))
    kept.get(2, lambda: made.append("again") or np.zeros(100))
    assert made == [0, 1, 2, 3, 4]  # 2, 3, 4 kept: three arrays of 800 bytes
    kept.get(1, lambda: made.append(1) or np.ones(100))
    assert made == [0, 1, 2, 3, 4, 1]


def test_a_value_over_the_bound_is_still_kept_alone() -> None:
    kept: Kept[np.ndarray] = Kept(16, max_bytes=100)
    big = kept.get("big", lambda: np.zeros(1000))
    assert kept.get("big", lambda: np.ones(1)) is big


def test_the_count_bound_still_holds() -> None:
    kept: Kept[int] = Kept(2)
    made = []
    for k in (1, 2, 3, 1):
        kept.get(k, lambda k=k: made.append(k) or k)
    assert made == [1, 2, 3, 1]


def test_a_value_no_longer_valid_is_made_again() -> None:
    source = np.arange(3.0)
    kept: Kept[tuple[np.ndarray, np.ndarray]] = Kept(4)
    made = []

    def make() -> tuple[np.ndarray, np.ndarray]:
        made.append(source.copy())
        return source, source.copy()

    def same(entry: tuple[np.ndarray, np.ndarray]) -> bool:
        return bool(np.array_equal(entry[0], entry[1]))

    first = kept.get(id(source), make, same)
    assert kept.get(id(source), make, same) is first
    source[0] = 7.0  # changed in place: the same id, other values
    again = kept.get(id(source), make, same)
    assert again is not first and again[1][0] == 7.0
    assert len(made) == 2 and len(kept._values) == 1


def test_values_per_object_go_by_identity_and_pickle_empty() -> None:
    per = PerObject()
    a, b = np.zeros(2), np.zeros(2)  # equal, but two objects
    made = []
    for obj in (a, b, a, b):
        per.get(obj, lambda obj=obj: made.append(obj) or len(made))
    assert per.get(a, lambda: 0) == 1 and per.get(b, lambda: 0) == 2
    assert per.get(a, lambda: 9, kind="other") == 9
    assert len(made) == 2
    copy = pickle.loads(pickle.dumps(per))
    assert copy.get(a, lambda: "new") == "new"
