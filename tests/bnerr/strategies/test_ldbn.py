"""Tests for bnerr.strategies.ldbn: the LDBN strategies read their key sets at the frame's offset or
slice."""

from bnerr.masks import frame_offset
from bnerr.strategies import (
    make_strategy,
)
from tests.bnerr.strategies._renders import hash_render


def test_ldbn_strategies_read_their_key_sets_at_the_frames_offset_or_slice():
    from bnerr.strategies.ldbn import LDBN_SETS

    for name in ("ldbn", "ldbn_fast", "ldbn_atrous", "ldbn_st"):
        record: list = []
        strategy = make_strategy(name, 6, 9, seed=2, spp=3)
        for t in range(5):
            strategy.frame(t, hash_render(record))
        frames = LDBN_SETS[name][1]
        first = record[0][1]
        assert first.level == 2 and first.spp == 3  # the tile for 4 spp serves 3
        for t, (_, sampler) in enumerate(record):
            assert sampler.name == "ldbn" and sampler.keys.dims == 8
            if name == "ldbn_st":  # slice t mod F at one offset per seed set
                assert sampler.keys is strategy.keys[t % frames] and sampler.offset == first.offset
            else:  # one tile shifted by the R2 step per frame
                dy, dx = frame_offset(t, 64)
                assert sampler.keys is strategy.keys[0]
                assert sampler.offset == ((first.offset[0] + dy) % 64, (first.offset[1] + dx) % 64)
        assert len({int(s[0, 0]) for s, _ in record}) == 5  # fresh per-pixel seeds per frame


def _keys_128(levels: int = 7, dims: int = 12):
    """Random keys of the ldbn128 shape: 128 x 128 tiles, levels to 64 spp, D = 12."""
    import torch

    from bnerr.sequences import LDBNKeys

    gen = torch.Generator().manual_seed(3)
    scramble = torch.randint(0, 1 << 24, (levels, 128, 128, dims), generator=gen, dtype=torch.int32)
    rank = torch.stack(
        [torch.randint(0, 1 << lv, (128, 128, dims // 2), generator=gen) for lv in range(levels)]
    )
    return LDBNKeys(scramble, rank.to(torch.int32), seed0=18)


def test_ldbn128_reads_any_shape_of_keys_and_is_registered_only_when_shipped():
    import torch

    from bnerr.strategies import STRATEGIES, strategy_identity
    from bnerr.strategies.ldbn import LDBN128_SHIPPED, LDBN128Strategy

    assert ("ldbn128" in STRATEGIES) == LDBN128_SHIPPED
    assert (LDBN128Strategy.family, LDBN128Strategy.rank) == ("ldbn", 65)
    assert "Owen" in LDBN128Strategy.raw_mse_note
    if LDBN128_SHIPPED:
        assert strategy_identity("ldbn128").family == "ldbn"
    strategy = LDBN128Strategy(5, 7, keys=[_keys_128()], spp=64, seed=1)
    record: list = []
    for t in range(2):
        strategy.frame(t, hash_render(record))
    sampler = record[0][1]
    assert sampler.level == 6 and sampler.keys.dims == 12 and sampler.keys.size == 128
    # the native kernel and the torch path agree on every keyed dimension and past them
    seeds = torch.arange(35, dtype=torch.int64) * 977
    index = torch.arange(35) % 64
    pixel = torch.stack([torch.arange(35) // 7, torch.arange(35) % 7], 1)
    want = torch.empty(14, 35)
    sampler._values_torch(seeds, index, 0, pixel, want)
    assert torch.equal(sampler.sample(seeds, index, 0, 14, pixel), want.T)


def test_ldbn128_renders_from_its_shipped_table():
    import pytest

    from bnerr.strategies.ldbn import LDBN128_FILE, LDBN128_SHIPPED

    if not LDBN128_SHIPPED:
        pytest.skip(f"bnerr/data/{LDBN128_FILE} is not shipped (made by benchmarks/ldbn_device.sh)")
    strategy = make_strategy("ldbn128", 6, 9, seed=2, spp=64)
    record: list = []
    strategy.frame(0, hash_render(record))
    assert record[0][1].keys.size == 128 and record[0][1].level == 6


def test_keys_over_other_bases_render_like_ldbn_and_register_only_when_shipped():
    import torch

    from bnerr.ldbn.keys import KIND_BASES, shipped_ldbn
    from bnerr.sequences import LDBNKeys
    from bnerr.strategies import STRATEGIES
    from bnerr.strategies.ldbn import LDBNLatticeStrategy, LDBNZOrderStrategy

    assert {LDBNLatticeStrategy.kind, LDBNZOrderStrategy.kind} == set(KIND_BASES)
    for cls in (LDBNLatticeStrategy, LDBNZOrderStrategy):
        shipped = f"ldbn_{cls.kind}_64.npy" in shipped_ldbn()
        assert (cls.label in STRATEGIES) == shipped and cls.family == "ldbn"
        assert cls.raw_mse_note
        chunks = torch.stack([torch.randperm(16) for _ in range(6)]).reshape(3, 4, 4, 2)
        scramble = torch.stack([chunks, torch.zeros_like(chunks)], -1).reshape(3, 4, 4, 4)
        if cls.kind == "lattice":
            scramble = torch.randint(0, 1 << 24, (3, 4, 4, 4))
        rank = torch.stack([torch.randint(0, 1 << lv, (4, 4, 2)) for lv in range(3)])
        keys = LDBNKeys(scramble.to(torch.int32), rank.to(torch.int32), 18, cls.kind)
        record: list = []
        cls(5, 7, keys=[keys], spp=4, seed=1).frame(0, hash_render(record))
        sampler = record[0][1]
        assert sampler.keys.base == cls.kind and sampler.level == 2
        seeds = torch.arange(35, dtype=torch.int64)
        pixel = torch.stack([torch.arange(35) // 7, torch.arange(35) % 7], 1)
        values = sampler.sample(seeds, torch.arange(35) % 8, 0, 6, pixel)
        assert values.shape == (35, 6) and float(values.min()) >= 0 and float(values.max()) < 1
