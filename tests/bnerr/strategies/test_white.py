"""Tests for bnerr.strategies.white: fresh, distinct seeds every frame."""

from bnerr.strategies import (
    make_strategy,
)
from tests.bnerr.strategies._renders import hash_render


def test_white_seeds_are_fresh_and_distinct_every_frame():
    record: list = []
    strategy = make_strategy("white", 16, 24, seed=1)
    for t in range(3):
        strategy.frame(t, hash_render(record))
    seeds = [s for s, _ in record]
    assert all(s.unique().numel() == 16 * 24 for s in seeds)
    assert (seeds[0] != seeds[1]).float().mean() > 0.99
    assert isinstance(record[0][1], type(make_strategy("temporal", 4, 4).sampler))  # same sampler
