"""Tests of bnerr.sequences.bnds: the shared sequence rotated by the mask, its table and direct
paths, the white-noise fallback beyond the mask, pixels of one texel sharing values, values below
one, typed errors."""

from __future__ import annotations

import pytest
import torch

from bnerr.errors import DtypeError, ShapeError, ValueRangeError
from bnerr.sequences import (
    ONE_MINUS_EPS,
    BNDSSampler,
    owen_sobol,
    white,
)
from tests.bnerr.sequences._samplers import lanes, small_bnds


def test_bnds_stays_below_one_when_the_sum_rounds_up():
    # mask values just below 1 added to sequence values just below 1 (and everything between)
    mask = torch.full((2, 4, 4), ONE_MINUS_EPS)
    mask[1] = torch.linspace(0, ONE_MINUS_EPS, 16).reshape(4, 4)
    sampler = BNDSSampler(mask, seed0=1)
    n = 4096
    index = torch.arange(n, dtype=torch.int64)
    pixel = torch.stack([index % 4, (index // 4) % 4], dim=1)
    values = sampler.sample(torch.zeros(n, dtype=torch.int64), index, 0, 2, pixel)
    # the bound written out: the largest float32 below 1 (0x3F7FFFFF), not the module's constant
    largest_below_one = 1.0 - 2.0**-24
    assert ONE_MINUS_EPS == largest_below_one
    assert float(values.max()) <= largest_below_one and float(values.min()) >= 0


def test_bnds_is_the_shared_sequence_rotated_by_the_mask():
    sampler = small_bnds(dims=4, size=16, seed0=3)
    n = 2000
    g = torch.Generator().manual_seed(4)
    seed = torch.randint(0, 2**32, (n,), generator=g)
    index = torch.randint(0, 32, (n,), generator=g)
    pixel = torch.randint(-40, 200, (n, 2), generator=g)
    got = sampler.sample(seed, index, 1, 3, pixel)
    y, x = (pixel[:, 0] + 5) % 16, (pixel[:, 1] + 9) % 16
    for j, d in enumerate(range(1, 4)):
        shared = owen_sobol(torch.tensor(3), index, d)  # the same sequence for every pixel
        expect = torch.remainder(shared.double() + sampler.mask[d, y, x].double(), 1.0)
        assert torch.allclose(got[:, j].double(), expect, atol=2**-23, rtol=0)


def test_bnds_shared_sequence_table_and_direct_paths_agree_exactly():
    # Indices below N take the evaluate-once-and-gather path; a lane alone with index >= 1 takes
    # the direct path. Both must give the same bits.
    sampler = small_bnds(dims=6, size=16)
    n = 64
    index = torch.arange(n, dtype=torch.int64).flip(0) % 17
    seed = torch.arange(n, dtype=torch.int64)
    pixel = torch.stack([seed % 16, seed // 16], dim=1)
    together = sampler.sample(seed, index, 1, 5, pixel)
    alone = torch.cat([sampler.sample(seed[i : i + 1], index[i : i + 1], 1, 5, pixel[i : i + 1])
                       for i in range(n)])  # fmt: skip
    assert torch.equal(together, alone)


def test_bnds_falls_back_to_per_pixel_white_noise_beyond_the_mask():
    sampler = small_bnds(dims=4)
    n = 500
    seed = torch.arange(n, dtype=torch.int64) * 31
    index = torch.arange(n, dtype=torch.int64) % 7
    pixel = torch.stack([index, index], dim=1)
    got = sampler.sample(seed, index, 2, 5, pixel)  # dims 2, 3 rotated; 4, 5, 6 white
    for j, d in enumerate(range(4, 7)):
        assert torch.equal(got[:, 2 + j], white(seed, index, d))
    # beyond D the pixel's own seed matters; inside D only the pixel position does
    other = sampler.sample(seed + 1, index, 2, 5, pixel)
    assert torch.equal(got[:, :2], other[:, :2]) and not torch.equal(got[:, 2:], other[:, 2:])


def test_bnds_pixels_with_the_same_mask_texel_share_values():
    sampler = small_bnds(dims=2, size=8)
    index = torch.tensor([3, 3], dtype=torch.int64)
    pixel = torch.tensor([[1, 2], [1 + 8, 2 - 16]], dtype=torch.int64)  # one tile apart
    got = sampler.sample(torch.tensor([10, 99], dtype=torch.int64), index, 0, 2, pixel)
    assert torch.equal(got[0], got[1])


def test_bnds_rejects_bad_input():
    seed, index = lanes()
    with pytest.raises(ShapeError, match=r"pixel: expected a \[N, 2\] int64 tensor .* got None"):
        small_bnds().sample(seed, index, 0, 2)
    with pytest.raises(ShapeError, match=r"mask: expected 3 dimensions \[D, T, T\]"):
        BNDSSampler(torch.zeros(4, 4))
    with pytest.raises(ShapeError, match=r"mask: expected shape \[D, T, T\] \(T equal"):
        BNDSSampler(torch.zeros(2, 4, 8))
    with pytest.raises(DtypeError, match="mask: expected dtype float32, got float64"):
        BNDSSampler(torch.zeros(2, 4, 4, dtype=torch.float64))
    with pytest.raises(ValueRangeError, match=r"mask: expected values in \[0, 1\), got min 0.0"):
        BNDSSampler(torch.ones(2, 4, 4).tril())
    with pytest.raises(DtypeError, match=r"offset: expected a pair of ints \(oy, ox\)"):
        BNDSSampler(torch.zeros(2, 4, 4), offset=(1.5, 0))
    with pytest.raises(DtypeError, match="seed0: expected an int, got str"):
        BNDSSampler(torch.zeros(2, 4, 4), seed0="1")
