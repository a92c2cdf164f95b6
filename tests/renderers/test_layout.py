"""Tests for renderers.layout: each dimension has exactly one use; 2D decisions are pair-aligned."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from bnerr.errors import DtypeError, ValueRangeError
from renderers.layout import Layout


def expected_dimensions(max_depth: int, lights: int, medium: bool) -> int:
    """2 pixel + 2 light per vertex + 2 direction per vertex but the last + 1D decisions."""
    vertices = max_depth - 1
    one_d = (1 if medium else 0) + (1 if lights > 1 else 0)
    return 2 + 2 * vertices + 2 * (vertices - 1) + one_d * vertices


@given(st.integers(2, 12), st.integers(1, 4), st.booleans())
def test_every_dimension_used_once_and_pairs_aligned(max_depth, lights, medium):
    layout = Layout(max_depth, lights, medium)
    assert layout.dimensions == expected_dimensions(max_depth, lights, medium)
    used = [0, 1]
    for k in range(layout.vertices):
        pairs = [layout.light(k)] + (
            [layout.direction(k)] if layout.direction(k) is not None else []
        )
        for first in pairs:
            assert first % 2 == 0, "a 2D decision must start on an even dimension"
            used += [first, first + 1]
        singles = [layout.distance(k), layout.light_choice(k)]
        assert (singles[0] is not None) == medium
        assert (singles[1] is not None) == (lights > 1)
        used += [d for d in singles if d is not None]
    assert sorted(used) == list(range(layout.dimensions))
    assert len(layout.describe()) == layout.dimensions


def test_last_vertex_samples_no_direction():
    layout = Layout(6)
    assert [layout.direction(k) is None for k in range(5)] == [False] * 4 + [True]


@pytest.mark.parametrize(
    ("max_depth", "lights", "medium", "dimensions"),
    [(2, 1, False, 4), (3, 1, False, 8), (6, 1, False, 20), (3, 2, False, 10), (9, 1, True, 40)],
)
def test_named_cases(max_depth, lights, medium, dimensions):
    assert Layout(max_depth, lights, medium).dimensions == dimensions


def test_bad_input():
    with pytest.raises(ValueRangeError, match="max_depth: expected an integer >= 2, got 1"):
        Layout(1)
    with pytest.raises(ValueRangeError, match="lights: expected an integer >= 1, got 0"):
        Layout(3, 0)
    with pytest.raises(DtypeError, match="max_depth: expected an integer"):
        Layout(2.5)
