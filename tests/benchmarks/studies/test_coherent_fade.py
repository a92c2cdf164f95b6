"""The cause measures of benchmarks.studies.coherent_fade on images whose answer is known by
construction."""

from __future__ import annotations

import pytest
import torch

from benchmarks.studies.coherent_fade import block_spread, coherent_blocks, key_error_correlation
from bnerr.errors import ShapeError


def _gray(plane: torch.Tensor) -> torch.Tensor:
    return plane.expand(3, *plane.shape).clone()  # equal channels: luminance == the plane


def test_coherent_blocks_are_the_whole_tiles_inside_the_mask():
    mask = torch.ones(9, 8, dtype=torch.bool)
    mask[5, 1] = False
    want = torch.tensor([[True, True], [False, True]])
    assert torch.equal(coherent_blocks(mask, 4), want)  # row 8 is not a whole tile: left out
    with pytest.raises(ShapeError):
        coherent_blocks(torch.ones(3, 3, dtype=torch.bool), 4)


def test_spread_is_the_ratio_of_the_within_block_deviations():
    gen = torch.Generator().manual_seed(1)
    err = _gray(torch.randn(8, 8, generator=gen, dtype=torch.float64))
    mask = torch.ones(8, 8, dtype=torch.bool)
    assert block_spread(3.0 * err, err, mask) == pytest.approx(3.0, rel=1e-12)
    assert block_spread(err + 5.0, err, mask) == pytest.approx(1.0, rel=1e-12)  # offsets: none
    assert block_spread(err, err, torch.zeros(8, 8, dtype=torch.bool)) != block_spread(
        err, err, mask
    )  # no block: NaN


def test_the_key_ranks_the_error_only_when_the_signal_is_flat_inside_blocks():
    gen = torch.Generator().manual_seed(2)
    err = _gray(torch.randn(8, 8, generator=gen, dtype=torch.float64))
    mask = torch.ones(8, 8, dtype=torch.bool)
    flat = _gray(torch.full((8, 8), 2.0, dtype=torch.float64))
    assert key_error_correlation(flat + err, flat, mask) == pytest.approx(1.0)
    ramp = _gray(torch.arange(64, dtype=torch.float64).reshape(8, 8) * 100.0)
    # a steep ramp inside each block: the key is the ramp's order, unrelated to the error
    assert abs(key_error_correlation(ramp + err, ramp, mask)) < 0.5
