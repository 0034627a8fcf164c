"""Property tests are derandomized everywhere (issue 12, item 5): CI gives one verdict."""

from hypothesis import given, settings
from hypothesis import strategies as st

DRAWN: list[list[int]] = []


def test_loaded_profile_is_derandomized_without_a_database():
    assert settings.default.derandomize
    assert settings.default.database is None
    assert settings(max_examples=3).derandomize


def test_two_runs_of_a_property_draw_the_same_examples():
    @settings(max_examples=20)
    @given(st.integers(0, 10**9))
    def draw(n):
        DRAWN[-1].append(n)

    for _ in range(2):
        DRAWN.append([])
        draw()
    assert DRAWN[0] == DRAWN[1]
    assert len(set(DRAWN[0])) > 5
