"""Tests for bnerr.strategies.dithered: bnds dithers by the vector mask at the frame's offset and
picks the mask that covers the integrand; bnds_st gives each dimension pair its own STBN slice."""

import torch

from bnerr import strategies
from bnerr.masks import frame_offset
from bnerr.masks.stbn import load_stbn
from bnerr.sequences import BNDSSampler
from bnerr.strategies import (
    BNDSStrategy,
    dithered,
    make_strategy,
)
from tests.bnerr.strategies._renders import hash_render


def test_bnds_dithers_by_the_vector_mask_at_the_frame_offset():
    record: list = []
    mask = torch.rand(2, 64, 64, generator=torch.Generator().manual_seed(0))
    strategy = BNDSStrategy(20, 30, seed=2, mask=mask)
    for t in range(3):
        strategy.frame(t, hash_render(record))
    samplers = [s for _, s in record]
    assert all(isinstance(s, BNDSSampler) for s in samplers)
    assert [s.offset for s in samplers] == [frame_offset(t, 64) for t in range(3)]
    assert len({s.seed0 for s in samplers}) == 3  # a fresh shared sequence every frame
    assert record[0][0].unique().numel() == 20 * 30


def test_bnds_takes_the_vector_mask_with_the_fewest_channels_covering_the_integrand(monkeypatch):

    shipped = [("scalar", 64), ("vector", 64, 2), ("vector", 64, 4), ("vector", 64, 8)]
    monkeypatch.setattr(dithered, "shipped_masks", lambda: shipped)
    monkeypatch.setattr(
        dithered, "load_mask", lambda kind, size, dims=None: torch.zeros(dims, size, size)
    )
    for dimensions, want in ((None, 2), (2, 2), (3, 4), (8, 8), (20, 8)):
        strategy = make_strategy("bnds", 8, 8, dimensions=dimensions)
        assert strategy.mask.shape == (want, 64, 64), dimensions
    assert make_strategy("bnds", 8, 8, dimensions=20, mask_dims=4).mask.shape[0] == 4


def test_bnds_st_gives_each_dimension_pair_its_own_stbn_slice():
    stbn = load_stbn("vector", 64, 32)
    record: list = []
    strategy = make_strategy("bnds_st", 16, 16, seed=0, dimensions=7)  # 8 channels: 4 pairs
    assert strategy.pairs == 4 and strategy.slice_step == 8
    for t in range(3):
        strategy.frame(t, hash_render(record))
    for t, (seeds, sampler) in enumerate(record):
        assert isinstance(sampler, BNDSSampler) and sampler.offset == (0, 0)
        assert strategy.slices(t) == [t, t + 8, t + 16, t + 24]
        want = torch.cat([stbn[(t + 8 * k) % 32] for k in range(4)])
        assert torch.equal(sampler.mask, want) and sampler.dims == 8
        assert seeds.unique().numel() == 16 * 16
    assert len({s.seed0 for _, s in record}) == 3
    assert make_strategy("bnds_st", 8, 8, dimensions=2).pairs == 1
    assert make_strategy("bnds_st", 8, 8, dimensions=3).pairs == 2  # as bnds: 4 channels
    assert strategies.BNDSSTStrategy(8, 8, stbn=stbn, channels=2).slices(33) == [1]
