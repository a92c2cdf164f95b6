"""The short-moves measures of benchmarks.studies.short_moves, on seed images whose answer is
known."""

from __future__ import annotations

import pytest
import torch

from benchmarks.studies.short_moves import mean_move, measure_field, seed_carryover
from bnerr.errors import ShapeError


def _seeds(h: int, w: int) -> torch.Tensor:
    return torch.randperm(h * w, generator=torch.Generator().manual_seed(3)).reshape(h, w)


def _swap_columns(x: torch.Tensor) -> torch.Tensor:
    """Columns 0 <-> 1, 2 <-> 3, ...: every pixel moves 1 px."""
    return x.reshape(x.shape[0], -1, 2).flip(2).reshape(x.shape)


def test_an_error_that_travels_with_its_seed_carries_over_fully():
    gen = torch.Generator().manual_seed(4)
    seeds, err = _seeds(8, 8), torch.randn(8, 8, generator=gen, dtype=torch.float64)
    assert seed_carryover(seeds, err, _swap_columns(seeds), _swap_columns(err)) == pytest.approx(1)
    # the error left at the old pixel while the seed moved: no carry-over to speak of
    fresh = torch.randn(64, 64, generator=gen, dtype=torch.float64)
    big = _seeds(64, 64)
    assert abs(seed_carryover(big, fresh, _swap_columns(big), fresh)) < 4 / 64  # 4 sigma
    with pytest.raises(ShapeError):
        seed_carryover(seeds, err, seeds[:4], err[:4])


def test_mean_move_counts_pixels_between_a_seeds_positions():
    seeds = _seeds(6, 8)
    assert mean_move(seeds, seeds) == 0.0
    assert mean_move(seeds, _swap_columns(seeds)) == pytest.approx(1.0)
    assert mean_move(seeds, seeds + 1000) != mean_move(seeds, seeds)  # no shared seed: NaN


def test_shorter_moves_trade_mask_match_for_distance():
    short = measure_field("direct", 4, 1, "luminance", size=32, warmup=1, frames=2)
    shipped = measure_field("direct", 4, 6, "luminance", size=32, warmup=1, frames=2)
    assert short["mask_mismatch"] > shipped["mask_mismatch"]  # the exact optimum over a subset
    assert short["move"] < shipped["move"]
    assert -1.0 <= short["carryover"] <= 1.0
