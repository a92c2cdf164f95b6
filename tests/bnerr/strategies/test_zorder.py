"""Tests for bnerr.strategies.zorder: ZSobol's Morton keys with a fresh scramble per frame,
ZSobol-T's one scramble moving to the frame's block, Cycles' blue-noise keys fresh every frame."""

import torch

from bnerr import strategies
from bnerr.sequences import cycles_keys, zsobol_2d, zsobol_keys
from bnerr.strategies import (
    make_strategy,
)
from tests.bnerr.strategies._renders import hash_render, pixels


def test_zsobol_keys_are_the_identity_morton_image_and_the_scramble_is_fresh_per_frame():
    record: list = []
    strategy = make_strategy("zsobol", 6, 9, seed=2, spp=4)
    for t in range(3):
        strategy.frame(t, hash_render(record))
    for seeds, sampler in record:
        assert torch.equal(seeds, zsobol_keys(6, 9))
        assert sampler.samples_per_pixel == 4 and sampler.layout.width == 9
    assert len({sampler.seed for _, sampler in record}) == 3
    # frame 0 is exactly pbrt's ZSobol with that seed: pair 0 is GetPixel2D
    seeds, sampler = record[0]
    want = zsobol_2d(torch.tensor(4), torch.tensor(3), torch.tensor(1), 0,
                     seed=sampler.seed, width=9, height=6, spp=4)  # fmt: skip
    got = sampler.sample(seeds[3, 4].reshape(1), torch.tensor([1]), 0, 2, pixels(1, 1))
    assert torch.equal(got[0], want)


def test_zsobol_t_keeps_one_scramble_and_moves_to_the_frames_block():
    record: list = []
    strategy = make_strategy("zsobol_t", 8, 8, seed=1, spp=2)
    for t in range(4):
        strategy.frame(t, hash_render(record))
    assert [sampler.frame for _, sampler in record] == [0, 1, 2, 3]
    assert len({sampler.seed for _, sampler in record}) == 1
    assert all(torch.equal(seeds, zsobol_keys(8, 8)) for seeds, _ in record)
    assert not strategy.stateful


def test_cycles_blue_keys_are_distinct_and_fresh_every_frame():
    record: list = []
    strategy = make_strategy("cycles_blue", 12, 20, seed=3, spp=3)  # any spp
    for t in range(3):
        strategy.frame(t, hash_render(record))
    keys = [seeds for seeds, _ in record]
    assert all(k.unique().numel() == 12 * 20 for k in keys)
    assert torch.equal(keys[0], cycles_keys(12, 20, _cycles_seed(3, 0)))
    assert (keys[0] != keys[1]).float().mean() > 0.9
    assert all(s.name == "cycles_pure" and s.spp == 3 and s.seed0 == 0 for _, s in record)


def _cycles_seed(seed: int, t: int) -> int:
    return strategies.stream_key(seed, t, strategies.CyclesBlueStrategy.stream)
